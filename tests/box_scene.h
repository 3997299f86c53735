/*
 * box_scene.h: the Cornell box of bench/path/scenes.py for the tests that
 * render it (test_path.c, test_light_paths.c): its camera, walls and
 * spheres as JSON fragments, and the whole small box.
 */
#ifndef LR_TEST_BOX_SCENE_H
#define LR_TEST_BOX_SCENE_H

/* The Cornell box of bench/path/scenes.py (open to the camera), small:
 * its camera, its five walls and its two spheres (diffuse, and rough
 * metal), lit by an emitting rectangle under the ceiling. */
#define BOX_CAMERA                                                    \
    " \"camera\": {\"position\": [0, 5, 16], \"look_at\": [0, 5, 0]," \
    "  \"fov\": 40},"
#define BOX_WALLS                                                             \
    "  {\"type\": \"plane\", \"point\": [0, 0, -5], \"normal\": [0, 1, 0],"   \
    "   \"size\": 10, \"material\": \"w\"},"                                  \
    "  {\"type\": \"plane\", \"point\": [0, 10, -5], \"normal\": [0, -1, 0]," \
    "   \"size\": 10, \"material\": \"w\"},"                                  \
    "  {\"type\": \"plane\", \"point\": [0, 5, -10], \"normal\": [0, 0, 1],"  \
    "   \"size\": 10, \"material\": \"w\"},"                                  \
    "  {\"type\": \"plane\", \"point\": [-5, 5, -5], \"normal\": [1, 0, 0],"  \
    "   \"size\": 10, \"material\": \"w\"},"                                  \
    "  {\"type\": \"plane\", \"point\": [5, 5, -5], \"normal\": [-1, 0, 0],"  \
    "   \"size\": 10, \"material\": \"w\"},"
#define BOX_SPHERES                                                      \
    "  {\"type\": \"sphere\", \"center\": [-2, 2, -6.5], \"radius\": 2," \
    "   \"material\": \"w\"},"                                           \
    "  {\"type\": \"sphere\", \"center\": [2.2, 1.8, -3],"               \
    "   \"radius\": 1.8, \"material\": \"m\"}]}"
static const char *const cornell_json =
    "{\"render\": {\"width\": 24, \"height\": 16, \"spp\": 20,"
    "  \"integrator\": \"path\", \"adaptive\": false, \"max_depth\": 6,"
    "  \"plan\": false, \"threads\": 1}," BOX_CAMERA
    " \"materials\": {\"w\": {\"diffuse\": 0.75},"
    "  \"m\": {\"reflect\": 0.9, \"roughness\": 0.25},"
    "  \"e\": {\"diffuse\": 0, \"emission\": 30}},"
    " \"objects\": [" BOX_WALLS
    "  {\"type\": \"plane\", \"point\": [0, 9.99, -5],"
    "   \"normal\": [0, -1, 0], \"size\": 3, \"material\": \"e\"}," BOX_SPHERES;

#endif
