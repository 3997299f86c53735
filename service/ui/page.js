// page.js: the page of lensrayd (docs/page.md).  It only calls the
// daemon's API (docs/api.md): the models, their keys and the names it may
// send come from GET /v1/options, the scenes from GET /v1/scenes, so a
// camera model added to the library shows up here with its keys.
//
// A picture is a series of jobs at rising samples per pixel (1, 4, 16,
// ... up to the chosen spp).  Every change starts a new series; the job
// of the series it supersedes is cancelled on the daemon with DELETE, so
// moving a slider never leaves stale work in the queue.
"use strict";

// How a known key is shown: a slider (min, max, step; log: a logarithmic
// scale) or a choice.  Keys the table does not know get a number box
// (numbers) or are sent back unchanged (anything else).
const KEY_HINTS = {
  fov: {min: 5, max: 120, step: 0.5, label: "field of view (degrees)"},
  focus_distance: {min: 0.1, max: 200, log: true, label: "focus distance"},
  sensor_width_mm: {min: 4, max: 60, step: 0.5, label: "sensor width (mm)"},
  aperture_radius: {min: 0, max: 2, step: 0.005, label: "aperture radius"},
  f_number: {min: 0, max: 32, step: 0.1, label: "f-number (0: the thin lens uses its radius, a real lens its own stop)"},
  focal_length_mm: {min: 0, max: 300, step: 1, label: "focal length (mm)"},
  aperture_shape: {choices: ["disk", "square", "polygon"], label: "aperture shape"},
  coating: {choices: ["prescription", "none", "mgf2"], label: "coatings (the prescription's, bare glass, or MgF2 on every surface)"},
  aperture_blades: {min: 3, max: 16, step: 1, label: "aperture blades"},
  aperture_rotation: {min: 0, max: 360, step: 1, label: "aperture rotation (degrees)"},
  aperture_ratio: {min: 0.25, max: 4, step: 0.05, label: "anamorphic ratio"},
  image_plane_distance: {min: 0.05, max: 20, log: true, label: "image plane distance"},
  focal_length: {min: 0.1, max: 200, log: true, label: "focal length (beyond the image plane)"},
  aperture: {min: 0, max: 2, step: 0.005, label: "aperture (square side)"},
  view_height: {min: 0.1, max: 200, log: true, label: "view height (orthographic, scene units)"},
};
// Set by the scene, never by a slider.
const FRAME_KEYS = ["model", "position", "look_at", "up", "focus_on", "chromatic"];
const SPP_CHOICES = [1, 4, 16, 64, 256, 1024, 4096, 16384, 65536];
const LOG_STEPS = 1000;

const $ = (id) => document.getElementById(id);
const state = {
  token: sessionStorage.getItem("lensray-token") || "",
  options: null,
  scenes: [],
  lenses: [],       // GET /v1/lenses: the ids of the shipped lenses
  scene: null,
  model: null,      // an entry of options.camera_models
  values: {},       // camera key -> value, as the controls say
  focusOn: null,    // [x, y] until the daemon has resolved it
  chromatic: {},    // the scene's camera.chromatic
  generation: 0,    // bumped by every change
  active: null,     // the job being rendered: {id, generation, deleted, polling}
  shown: null,      // the job whose picture is shown: {id, body, status, blob, plan}
  changedAt: 0,     // when the newest change was made (performance.now)
  keyPoint: [0.5, 0.5],  // the keyboard's point on the picture (fractions of its size)
  wired: false,     // the controls' handlers are attached
};

// ---- the API -------------------------------------------------------------

// The daemon gone (or a proxy in front of it failing) is an error the user
// reads, not the browser's bare "Failed to fetch".
async function api(method, path, body) {
  const headers = {};
  // A header carries printable ASCII only: fetch refused the whole
  // request for a typographic quote, and the page, with the token kept,
  // stayed locked even after a reload.
  if (state.token && !/^[\x21-\x7e]+$/.test(state.token)) {
    state.token = "";
    sessionStorage.removeItem("lensray-token");
    askToken("a token holds printable ASCII characters only (no spaces or typographic quotes)");
    throw new Error("unauthorized");
  }
  if (state.token) headers["Authorization"] = "Bearer " + state.token;
  if (body !== undefined) headers["Content-Type"] = "application/json";
  let res;
  try {
    res = await fetch(path, {
      method, headers, body: body === undefined ? undefined : JSON.stringify(body),
    });
  } catch (e) {
    throw new Error("the server does not answer (" + method + " " + path + ": " + e.message + ")");
  }
  if (res.status === 401) {
    askToken("the server refused the token");
    throw new Error("unauthorized");
  }
  return res;
}

// An answer's JSON; one that is not the daemon's JSON (a proxy's HTML
// error page, a connection cut mid-body) is named by its status.
async function answerJSON(res, method, path) {
  try {
    return await res.json();
  } catch (e) {
    throw new Error(method + " " + path + ": HTTP " + res.status + " " + res.statusText +
                    ", and no JSON answer (" + e.message + ")");
  }
}

// The message of a failed answer's document.
function answerError(res, doc) {
  return doc.error ? doc.error.message : "HTTP " + res.status + " " + res.statusText;
}

async function apiJSON(method, path, body) {
  const res = await api(method, path, body);
  const doc = await answerJSON(res, method, path);
  if (!res.ok) throw new Error(answerError(res, doc));
  return doc;
}

// A finished job's image, or an error naming why there is none.
async function apiImage(id) {
  const res = await api("GET", "/v1/jobs/" + id + "/image");
  if (!res.ok) {
    const doc = await res.json().catch(() => ({}));
    throw new Error(doc.error ? doc.error.message : "the image of job " + id + ": HTTP " + res.status);
  }
  return res.blob();
}

function askToken(why) {
  $("app").hidden = true;
  $("token-form").hidden = false;
  $("token-error").textContent = why || "";
  document.body.dataset.state = "token";
  $("token").focus();
}

// ---- controls -----------------------------------------------------------

function option(select, value, text) {
  const o = document.createElement("option");
  o.value = value;
  o.textContent = text === undefined ? value : text;
  select.appendChild(o);
}

function toSlider(hint, v) {
  if (!hint.log) return v;
  const t = Math.log(v / hint.min) / Math.log(hint.max / hint.min);
  return Math.round(Math.min(1, Math.max(0, t)) * LOG_STEPS);
}

function fromSlider(hint, s) {
  if (!hint.log) return Number(s);
  return hint.min * Math.pow(hint.max / hint.min, Number(s) / LOG_STEPS);
}

function shortNumber(v) {
  return typeof v === "number" ? String(Number(v.toPrecision(5))) : String(v);
}

// The "lens" model names its prescription in camera.lens, a key its
// default camera leaves out (there is no default lens): the page offers the
// daemon's shipped lenses for it.
function lensChoice(box) {
  if (state.model.name !== "lens" || !state.lenses.length) return;
  if (!state.lenses.includes(state.values.lens)) state.values.lens = state.lenses[0];
  const label = document.createElement("label");
  label.textContent = "lens ";
  const input = document.createElement("select");
  state.lenses.forEach((id) => option(input, id));
  input.id = "key-lens";
  input.value = state.values.lens;
  input.addEventListener("change", () => { state.values.lens = input.value; changed(); });
  label.append(input);
  box.appendChild(label);
}

// One control per key of the model that the scene does not place.
function buildCameraKeys() {
  const box = $("camera-keys");
  box.replaceChildren();
  lensChoice(box);
  for (const [key, def] of Object.entries(state.model.defaults)) {
    if (FRAME_KEYS.includes(key)) continue;
    if (!(key in state.values)) state.values[key] = def;
    const hint = KEY_HINTS[key] || {};
    const label = document.createElement("label");
    label.textContent = (hint.label || key) + " ";
    let input;
    if (hint.choices) {
      input = document.createElement("select");
      hint.choices.forEach((c) => option(input, c));
      input.value = state.values[key];
      input.addEventListener("change", () => { state.values[key] = input.value; changed(); });
    } else if (typeof def === "number" && hint.min !== undefined) {
      input = document.createElement("input");
      input.type = "range";
      input.min = hint.log ? 0 : hint.min;
      input.max = hint.log ? LOG_STEPS : hint.max;
      input.step = hint.log ? 1 : hint.step;
      input.value = toSlider(hint, state.values[key]);
      const out = document.createElement("output");
      out.id = "value-" + key;
      out.textContent = shortNumber(state.values[key]);
      // A screen reader says the value shown, not the slider's position
      // (0 to 1000 on a log scale).
      input.setAttribute("aria-valuetext", out.textContent);
      input.addEventListener("input", () => {
        state.values[key] = fromSlider(hint, input.value);
        out.textContent = shortNumber(state.values[key]);
        input.setAttribute("aria-valuetext", out.textContent);
        if (key === "focus_distance") state.focusOn = null;
        changed();
      });
      label.append(input, " ", out);
    } else if (typeof def === "number") {
      input = document.createElement("input");
      input.type = "number";
      input.step = "any";
      input.value = state.values[key];
      input.addEventListener("change", () => {
        const v = Number(input.value);
        // An emptied box is 0 to Number(), letters NaN: said as typed.
        if (input.value.trim() === "" || !Number.isFinite(v)) {
          setStatus("camera." + key + ": \"" + input.value + "\" is not a number", true);
          document.body.dataset.state = "error";
          return;
        }
        state.values[key] = v;
        changed();
      });
    } else if (typeof def === "string") {
      // A name the page has no list for (a lens of a model to come, say).
      input = document.createElement("input");
      input.type = "text";
      input.value = state.values[key];
      input.addEventListener("change", () => { state.values[key] = input.value; changed(); });
    } else {
      continue;  // sent back as the scene or the model has it
    }
    input.id = "key-" + key;
    input.dataset.key = key;
    if (!label.contains(input)) label.append(input);
    box.appendChild(label);
  }
  $("chromatic-box").hidden = !state.model.chromatic;
}

// A control shows a value the daemon chose (the focus of a click).
function setControl(key, v) {
  state.values[key] = v;
  const input = $("key-" + key);
  if (input && input.type === "range") {
    input.value = toSlider(KEY_HINTS[key] || {}, v);
    input.setAttribute("aria-valuetext", shortNumber(v));
  }
  const out = $("value-" + key);
  if (out) out.textContent = shortNumber(v);
}

function chooseModel(name) {
  state.model = state.options.camera_models.find((m) => m.name === name);
  $("model").value = name;
  state.focusOn = null;
  buildCameraKeys();
}

function chooseScene(name) {
  state.scene = state.scenes.find((s) => s.name === name);
  $("scene").value = name;
  $("scene-description").textContent = state.scene.description || "";
  state.values = {};
  for (const [k, v] of Object.entries(state.scene.camera))
    if (!FRAME_KEYS.includes(k)) state.values[k] = v;
  // The scene's chromatic object, sent back with the page's mode and
  // amplify on top (its glass, indices and focal model stay the scene's).
  state.chromatic = Object.assign({}, state.scene.camera.chromatic || {});
  $("chroma-mode").value = state.chromatic.mode || "off";
  $("chroma-amplify").value = state.chromatic.amplify === undefined ? 1 : state.chromatic.amplify;
  $("chroma-amplify-value").textContent = $("chroma-amplify").value;
  $("focus-pixel").textContent = "";
  $("focus-pixel").dataset.pixel = "";
  const spp = state.scene.render.spp;
  $("spp").value = String(SPP_CHOICES.find((c) => c >= spp) || SPP_CHOICES[SPP_CHOICES.length - 1]);
  $("sampler").value = state.scene.render.sampler;
  chooseModel(state.scene.camera.model);
  // A scene that focuses by a pixel (camera.focus_on): the same place of
  // the page's frame, as if clicked (its pixel is in the scene's frame,
  // and the page's size is another: 1/4 size missed or left the frame).
  const fo = state.scene.camera.focus_on;
  if (state.model.autofocus && Array.isArray(fo)) {
    const scale = Number($("size").value);
    const w = Math.max(1, Math.round(state.scene.render.width * scale));
    const h = Math.max(1, Math.round(state.scene.render.height * scale));
    state.focusOn = [Math.min(w - 1, Math.floor((fo[0] + 0.5) * scale)),
                     Math.min(h - 1, Math.floor((fo[1] + 0.5) * scale))];
  }
}

// ---- jobs ---------------------------------------------------------------

// The job body for `spp` samples per pixel, from the controls.
function jobBody(spp, format) {
  const camera = {model: state.model.name};
  for (const key of Object.keys(state.model.defaults))
    if (!FRAME_KEYS.includes(key) && key in state.values) camera[key] = state.values[key];
  if ($("key-lens")) camera.lens = state.values.lens;
  // A click's pixel until the daemon resolves it; else the controls'
  // focus, which must replace a scene's own focus_on (or the scene's
  // autofocus wins over every slider move).
  if (state.model.autofocus && state.focusOn) camera.focus_on = state.focusOn;
  else if (state.model.autofocus && state.scene.camera.focus_on) camera.focus_on = null;
  // "off" is sent too: a job's camera keys only replace the scene's.
  if (state.model.chromatic)
    camera.chromatic = $("chroma-mode").value === "off" ? {mode: "off"} :
      Object.assign({}, state.chromatic, {mode: $("chroma-mode").value,
                                          amplify: Number($("chroma-amplify").value)});
  const scale = Number($("size").value);
  return {
    scene: state.scene.name,
    camera,
    render: {
      width: Math.max(1, Math.round(state.scene.render.width * scale)),
      height: Math.max(1, Math.round(state.scene.render.height * scale)),
      spp,
      sampler: $("sampler").value,
    },
    output: {format: format || "png"},
  };
}

// 1, 4, 16, ... below the target, then the target.
function stages(target) {
  const out = [];
  for (let s = 1; s < target; s *= 4) out.push(s);
  out.push(target);
  return out;
}

// Cancels a job once, on the daemon.  (A second DELETE would remove the
// cancelled job from the daemon's table.)
async function cancel(job) {
  if (!job || job.deleted) return;
  job.deleted = true;
  try { await api("DELETE", "/v1/jobs/" + job.id); } catch (e) { /* gone */ }
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// POST /v1/jobs; a full queue's 429 is said and sent again after its
// Retry-After while the change is still the newest.  null: superseded.
async function postJob(body, generation) {
  for (;;) {
    const res = await api("POST", "/v1/jobs", body);
    const doc = await answerJSON(res, "POST", "/v1/jobs");
    if (res.ok) return doc;
    const msg = answerError(res, doc);
    if (res.status !== 429) throw new Error(msg);
    if (generation !== state.generation) return null;
    const wait = Math.min(60, Math.max(1, Number(res.headers.get("Retry-After")) || 1));
    setStatus(msg + "; trying again in " + wait + " s");
    for (let t = 0; t < wait * 10; t++) {
      if (generation !== state.generation) return null;
      await sleep(100);
    }
  }
}

// A click's autofocus that failed (the pixel sees nothing): said once,
// and the next change renders with the focus the controls show.
function dropFocusClick() {
  if (!state.focusOn) return;
  state.focusOn = null;
  $("focus-pixel").textContent = "";
  $("focus-pixel").dataset.pixel = "";
}

// Renders one job to the end, or until a newer change supersedes it.
// Returns its status document, or null when superseded: nothing a
// superseded job answers reaches the controls, the status line or the
// focus (a stale answer set the focus of an older click).
async function renderJob(body, generation) {
  const created = await postJob(body, generation);
  if (created === null) return null;
  const job = {id: created.id, generation, deleted: false, polling: false};
  if (generation !== state.generation) { await cancel(job); return null; }
  state.active = job;
  document.body.dataset.job = job.id;
  for (;;) {
    if (generation !== state.generation) { await cancel(job); return null; }
    // While a poll is out, a change leaves the DELETE to this loop: the
    // answer may say the job is finished, and a DELETE of a finished job
    // removes it (page.md keeps finished jobs for --job-ttl).
    job.polling = true;
    let st;
    try {
      st = await apiJSON("GET", "/v1/jobs/" + job.id);
    } finally {
      job.polling = false;
    }
    const finished = st.status === "done" || st.status === "failed" || st.status === "cancelled";
    if (finished) {
      job.deleted = true;  // no longer the page's to cancel
      if (state.active === job) state.active = null;
    }
    if (generation !== state.generation) { await cancel(job); return null; }
    if (st.camera) showFocus(st.camera);
    if (finished) return st;
    setStatus(st.status === "queued" ? "waiting for a worker (" + body.render.spp + " spp)"
              : "rendering " + body.render.spp + " spp: " + Math.round(st.progress * 100) + "%");
    // Polled often: a 1-spp picture takes tens of milliseconds.
    await sleep(st.status === "queued" ? 50 : 25);
  }
}

async function run() {
  const generation = ++state.generation;
  // A job whose poll is out is cancelled by its own series once the
  // answer says it is not finished (renderJob).
  if (state.active && !state.active.polling) await cancel(state.active);
  const target = Number($("spp").value);
  const list = stages(target);
  for (let i = 0; i < list.length; i++) {
    const body = jobBody(list[i]);
    document.body.dataset.state = "rendering";
    let st;
    try {
      st = await renderJob(body, generation);
    } catch (e) {
      if (generation === state.generation) {
        if (body.camera.focus_on) dropFocusClick();
        setStatus(e.message, true);
        document.body.dataset.state = "error";
      }
      return;
    }
    if (st === null || generation !== state.generation) return;
    if (st.status !== "done") {
      if (body.camera.focus_on) dropFocusClick();
      setStatus(st.error ? st.error.message : st.status, true);
      document.body.dataset.state = "error";
      return;
    }
    // Fetching the picture fails too when the daemon goes away after the
    // job: said on the page, as above, never an uncaught rejection.
    try {
      await show(st, body, generation, i === 0);
    } catch (e) {
      if (generation === state.generation) { setStatus(e.message, true); document.body.dataset.state = "error"; }
      return;
    }
    if (generation !== state.generation) return;
  }
  document.body.dataset.state = "done";
  setStatus("done: " + target + " spp");
}

// Shows a finished job's picture, plan and statistics.
async function show(st, body, generation, first) {
  const blob = await apiImage(st.id);
  const plan = await apiJSON("GET", "/v1/jobs/" + st.id + "/plan");
  if (generation !== state.generation) return;
  const img = $("picture");
  const loaded = new Promise((r, fail) => {
    img.onload = r;
    img.onerror = () => fail(new Error("the browser could not show job " + st.id + "'s image"));
  });
  if (state.shown && state.shown.url) URL.revokeObjectURL(state.shown.url);
  const url = URL.createObjectURL(blob);
  img.src = url;
  await loaded;
  if (first) {
    const ms = performance.now() - state.changedAt;
    document.body.dataset.firstPictureMs = ms.toFixed(0);
    state.firstMs = ms;
  }
  state.shown = {id: st.id, body, status: st, url, plan};
  img.dataset.job = st.id;
  drawPlan(plan);
  showStats(st);
  $("dl-png").href = url;
  $("dl-png").download = body.scene + "-" + st.id + ".png";
  const jobUrl = URL.createObjectURL(new Blob([JSON.stringify(body, null, 2) + "\n"], {type: "application/json"}));
  if ($("dl-job").href.startsWith("blob:")) URL.revokeObjectURL($("dl-job").href);
  $("dl-job").href = jobUrl;
  document.body.dataset.shown = st.id;
}

function showFocus(camera) {
  let d = null;
  if (typeof camera.focus_distance === "number" && state.model.name !== "bracket") d = camera.focus_distance;
  else if (typeof camera.focal_length === "number" && typeof camera.image_plane_distance === "number")
    d = camera.image_plane_distance + camera.focal_length;  // the bracket's focal plane, from the eye
  $("focus-distance").textContent = d === null ? "-" : shortNumber(d);
  $("focus-distance").dataset.value = d === null ? "" : String(d);
  // Once the daemon has resolved a click, the slider takes its focus.
  if (state.focusOn && !camera.focus_on) {
    for (const key of ["focus_distance", "focal_length"])
      if (key in state.model.defaults && typeof camera[key] === "number") setControl(key, camera[key]);
    state.focusOn = null;
  }
}

function showStats(st) {
  const s = st.stats, p = s.plan;
  const pct = (x) => (100 * x).toFixed(1) + "%";
  const rows = [
    ["samples per pixel", st.spp],
    ["size", s.width + " x " + s.height],
    ["render time", (s.seconds * 1000).toFixed(0) + " ms"],
    ["first picture after the change", state.firstMs === undefined ? "-" : state.firstMs.toFixed(0) + " ms"],
    ["samples", s.samples.toLocaleString("en") + " of " + p.full_samples.toLocaleString("en")],
    ["rays", s.rays.toLocaleString("en")],
    ["camera rays", p.camera_rays.toLocaleString("en") + " of " + p.full_camera_rays.toLocaleString("en")],
    ["lens sampled", pct(p.lens_pixels) + " of pixels"],
    ["colours apart", pct(p.chroma_pixels) + " of pixels"],
    ["job", st.id.slice(0, 8)],
  ];
  const dl = $("stats");
  dl.replaceChildren();
  for (const [k, v] of rows) {
    const dt = document.createElement("dt"), dd = document.createElement("dd");
    dt.textContent = k;
    dd.textContent = v;
    dl.append(dt, dd);
  }
}

// The plan's blocks over the picture: blue where the lens was sampled,
// magenta where the colours were traced apart.
function drawPlan(plan) {
  const cv = $("overlay");
  cv.width = plan.width;
  cv.height = plan.height;
  const g = cv.getContext("2d");
  g.clearRect(0, 0, cv.width, cv.height);
  let lens = 0, chroma = 0;
  plan.cells.forEach((row, y) => {
    for (let x = 0; x < row.length; x++) {
      const c = Number(row[x]);
      const px = x * plan.block, py = y * plan.block;
      if (c & 1) {
        lens++;
        g.fillStyle = "rgba(0, 150, 255, 0.3)";
        g.fillRect(px, py, plan.block, plan.block);
        g.strokeStyle = "rgba(0, 200, 255, 0.9)";
        g.strokeRect(px + 0.5, py + 0.5, plan.block - 1, plan.block - 1);
      }
      if (c & 2) {
        chroma++;
        g.strokeStyle = "rgba(255, 0, 200, 0.95)";
        g.beginPath();
        g.moveTo(px + 2, py + plan.block - 2);
        g.lineTo(px + plan.block - 2, py + 2);
        g.stroke();
      }
    }
  });
  cv.dataset.lensBlocks = String(lens);
  cv.dataset.chromaBlocks = String(chroma);
  cv.dataset.job = plan.id;
}

function setStatus(text, error) {
  $("status").textContent = text;
  $("status").className = error ? "error" : "";
}

// Every change starts a series; the body's data-series and data-state
// say which one the page is on and whether its picture is finished.
function changed() {
  state.changedAt = performance.now();
  state.firstMs = undefined;
  document.body.dataset.state = "rendering";
  document.body.dataset.series = String(state.generation + 1);
  run();
}

// ---- downloads ------------------------------------------------------------

async function downloadExr() {
  if (!state.shown) return;
  // The shown picture's job itself, as EXR (the controls may have moved
  // on: a scene or size chosen since is not what the picture shows).
  const body = JSON.parse(JSON.stringify(state.shown.body));
  body.output = {format: "exr"};
  setStatus("rendering the EXR ...");
  const job = await apiJSON("POST", "/v1/jobs", body);
  for (;;) {
    const st = await apiJSON("GET", "/v1/jobs/" + job.id);
    if (st.status === "done") break;
    if (st.status !== "queued" && st.status !== "running") { setStatus(st.error.message, true); return; }
    await sleep(100);
  }
  const blob = await apiImage(job.id);
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = body.scene + "-" + job.id + ".exr";
  document.body.appendChild(a);
  a.click();
  a.remove();
  setStatus("EXR saved: " + a.download);
}

// ---- start ----------------------------------------------------------------

// The status line is on the page's main part, hidden until the start
// succeeds: shown for the error, or the user would see a blank page.
function startFailed(e) {
  $("token-form").hidden = true;
  $("app").hidden = false;
  setStatus(e.message, true);
  document.body.dataset.state = "error";
}

async function start() {
  try {
    const health = await apiJSON("GET", "/healthz");
    if (health.token_required && !state.token) { askToken(""); return; }
  } catch (e) {
    if (e.message !== "unauthorized") startFailed(e);
    return;
  }
  try {
    state.options = await apiJSON("GET", "/v1/options");
    state.scenes = (await apiJSON("GET", "/v1/scenes")).scenes;
    // A daemon without real lenses has no such route (404): none offered.
    const lenses = await api("GET", "/v1/lenses");
    if (lenses.ok) state.lenses = (await lenses.json()).lenses.map((l) => l.id);
  } catch (e) {
    if (e.message !== "unauthorized") startFailed(e);
    return;
  }
  $("token-form").hidden = true;
  $("app").hidden = false;
  // start() runs again after a token is asked for mid-session (the
  // daemon restarted with another): the lists are made anew, not added to.
  for (const id of ["scene", "model", "sampler", "chroma-mode", "spp"]) $(id).replaceChildren();
  for (const s of state.scenes) option($("scene"), s.name);
  for (const m of state.options.camera_models) option($("model"), m.name);
  for (const s of state.options.samplers) option($("sampler"), s);
  for (const m of state.options.chromatic_modes) option($("chroma-mode"), m);
  for (const n of SPP_CHOICES) option($("spp"), String(n));
  const first = state.scenes.find((s) => s.name === "spheres") || state.scenes[0];
  if (!first) { setStatus("the server has no scenes", true); return; }
  chooseScene(first.name);
  if (!state.wired) wire();
  changed();
}

// The controls' handlers, attached once whatever the number of starts: a
// second set made every change start two series.
function wire() {
  state.wired = true;
  $("scene").addEventListener("change", () => { chooseScene($("scene").value); changed(); });
  $("model").addEventListener("change", () => { chooseModel($("model").value); changed(); });
  for (const id of ["sampler", "spp", "size", "chroma-mode"])
    $(id).addEventListener("change", changed);
  $("chroma-amplify").addEventListener("input", () => {
    $("chroma-amplify-value").textContent = $("chroma-amplify").value;
    changed();
  });
  $("show-plan").addEventListener("change", () => {
    $("overlay").hidden = !$("show-plan").checked;
    $("legend").hidden = !$("show-plan").checked;
  });
  $("picture").addEventListener("click", (e) => {
    const img = $("picture");
    focusAt(e.offsetX / img.clientWidth, e.offsetY / img.clientHeight);
  });
  // The keyboard's click: the arrow keys move a marker (a twentieth of
  // the picture a press), Enter or Space focuses there.
  $("picture").addEventListener("keydown", (e) => {
    const step = {ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1]}[e.key];
    if (step) {
      const p = state.keyPoint;
      for (const i of [0, 1]) p[i] = Math.min(0.975, Math.max(0.025, Math.round((p[i] + step[i] / 20) * 40) / 40));
      showKeyPoint();
    } else if (e.key === "Enter" || e.key === " ") {
      focusAt(state.keyPoint[0], state.keyPoint[1]);
    } else {
      return;
    }
    e.preventDefault();
  });
  $("picture").addEventListener("focus", showKeyPoint);
  $("picture").addEventListener("blur", () => { $("key-point").hidden = true; });
  $("dl-exr").addEventListener("click", () => downloadExr().catch((e) => setStatus(e.message, true)));
}

// A click (or Enter) on the picture at (fx, fy), fractions of its size:
// the next series focuses on that pixel.
function focusAt(fx, fy) {
  if (!state.shown || !state.model.autofocus) return;
  const w = state.shown.body.render.width, h = state.shown.body.render.height;
  const x = Math.min(w - 1, Math.max(0, Math.floor(fx * w)));
  const y = Math.min(h - 1, Math.max(0, Math.floor(fy * h)));
  state.focusOn = [x, y];
  $("focus-pixel").textContent = "(focused on pixel " + x + ", " + y + ")";
  $("focus-pixel").dataset.pixel = x + "," + y;
  changed();
}

function showKeyPoint() {
  const m = $("key-point");
  m.style.left = (100 * state.keyPoint[0]) + "%";
  m.style.top = (100 * state.keyPoint[1]) + "%";
  m.hidden = false;
}

$("token-form").addEventListener("submit", (e) => {
  e.preventDefault();
  state.token = $("token").value.trim();
  sessionStorage.setItem("lensray-token", state.token);
  start();
});

start();
