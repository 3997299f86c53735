#!/usr/bin/env node
// bunny-to-obj.js: converts the npm package `bunny` (the Stanford bunny as
// {positions: [[x, y, z], ...], cells: [[a, b, c], ...]}, 0-based) into a
// Wavefront OBJ file that lensray's OBJ reader loads.
//
// Usage: node scenes/bunny-to-obj.js PACKAGE_DIR OUT.obj
//
// The file is written as OUT.obj.tmp and renamed at the end, so a run that
// is interrupted or fails never leaves a half-written OUT.obj behind that
// make would then take as up to date.
'use strict';

const fs = require('fs');
const path = require('path');

function die(msg) {
  process.stderr.write(`bunny-to-obj.js: ${msg}\n`);
  process.exit(1);
}

function isFiniteNumber(x) {
  return typeof x === 'number' && Number.isFinite(x);
}

function main(argv) {
  if (argv.length !== 2) {
    die('usage: node bunny-to-obj.js PACKAGE_DIR OUT.obj');
  }
  const pkgDir = path.resolve(argv[0]);
  const out = argv[1];

  let pkgJson;
  try {
    pkgJson = JSON.parse(fs.readFileSync(path.join(pkgDir, 'package.json'), 'utf8'));
  } catch (e) {
    die(`${pkgDir} is not an npm package directory: ${e.message}`);
  }
  let bunny;
  try {
    bunny = require(pkgDir);
  } catch (e) {
    die(`cannot load the package in ${pkgDir}: ${e.message}`);
  }

  // Check the data before writing anything: a changed or corrupt package
  // should fail here with a reason, not produce an OBJ that fails later.
  const { positions, cells } = bunny;
  if (!Array.isArray(positions) || positions.length === 0) {
    die('the package has no `positions` array');
  }
  if (!Array.isArray(cells) || cells.length === 0) {
    die('the package has no `cells` array');
  }
  positions.forEach((p, i) => {
    if (!Array.isArray(p) || p.length !== 3 || !p.every(isFiniteNumber)) {
      die(`positions[${i}] is not three finite numbers`);
    }
  });
  cells.forEach((c, i) => {
    if (!Array.isArray(c) || c.length !== 3 ||
        !c.every((k) => Number.isInteger(k) && k >= 0 && k < positions.length)) {
      die(`cells[${i}] is not three vertex indices below ${positions.length}`);
    }
  });

  const lines = [
    '# The Stanford bunny (Stanford 3D Scanning Repository,',
    '# http://graphics.stanford.edu/data/3Dscanrep/), as packaged in the npm',
    `# package ${pkgJson.name}@${pkgJson.version} by Mikola Lysenko.`,
    '# Converted by scenes/bunny-to-obj.js; regenerate with',
    '# scenes/get-bunny.sh rather than editing by hand.',
    `# ${positions.length} vertices, ${cells.length} triangles.`,
  ];
  for (const p of positions) {
    lines.push(`v ${p[0]} ${p[1]} ${p[2]}`);
  }
  // OBJ indices start at 1; the package's start at 0.
  for (const c of cells) {
    lines.push(`f ${c[0] + 1} ${c[1] + 1} ${c[2] + 1}`);
  }

  const tmp = `${out}.tmp`;
  try {
    fs.writeFileSync(tmp, lines.join('\n') + '\n');
    fs.renameSync(tmp, out);
  } catch (e) {
    try {
      fs.unlinkSync(tmp);
    } catch (ignored) {
      // Nothing to clean up when the temporary file was never created.
    }
    die(`cannot write ${out}: ${e.message}`);
  }
  process.stdout.write(
    `bunny-to-obj.js: wrote ${out} (${positions.length} vertices, ${cells.length} triangles)\n`);
}

main(process.argv.slice(2));
