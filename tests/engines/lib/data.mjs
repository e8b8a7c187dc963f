// The bakes the engine_bakes fixture made (prepare.py): where they are and
// how to read them.
import fs from 'node:fs';
import path from 'node:path';
import { readCross } from './exr.mjs';

function bake(data, name, source) {
  const dir = path.join(data, name);
  const manifestFile = path.join(dir, 'manifest.json');
  if (!fs.existsSync(manifestFile)) throw new Error(`${manifestFile} is missing (the engine_bakes fixture makes it)`);
  return {
    dir,
    manifest: JSON.parse(fs.readFileSync(manifestFile, 'utf8')),
    sources: JSON.parse(fs.readFileSync(path.join(data, 'src', 'sources.json'), 'utf8')),
    source: path.join(data, 'src', source),
    sourceBabylon: path.join(data, 'src', source.replace('.exr', '_babylon.exr')),
    crossLevel: (m) => readCross(path.join(dir, `specular_${m}.exr`)),
  };
}

export function loadBakes(data) {
  const marker = bake(data, 'marker', 'marker.exr');
  return {
    marker,
    smooth: bake(data, 'smooth', 'smooth.exr'),
    other: (name, source = 'marker.exr') => bake(data, name, source),
    // SPEC chains with M levels (linear r_m = m / (M - 1)): the levels of the
    // deliberately wrong "linear curve" exports.
    // (The root bake's own chain when it has M levels.)
    markerLinear: (M) => {
      const b = marker.manifest.specular.length === M ? marker : bake(data, `marker_lin${M}`, 'marker.exr');
      return Array.from({ length: M }, (_, m) => b.crossLevel(m));
    },
  };
}

// The load snippet the export documents for an engine (docs/export.md "Load it in
// your engine"), extracted by prepare.py into web/snippets/<engine>.mjs;
// null when there is none.
export function snippetFor(engine) {
  const f = path.join(path.dirname(new URL(import.meta.url).pathname), '..', 'web', 'snippets', `${engine}.mjs`);
  return fs.existsSync(f) ? `/w/snippets/${engine}.mjs` : null;
}

// A preset's levels in SPEC orientation as the engine tests expect them: the
// file's levels (read by another library, mirror undone), but level 0 (r = 0,
// the source itself) from the bake's own EXR cross, so a face stored the
// wrong way round (flipped, rotated) shows in the renders too.
export function expectedLevels(bake, pre, fileLevelsSpec) {
  const out = fileLevelsSpec.slice();
  const root = bake.manifest.specular[0];
  if (pre.specular[0].roughness === 0 && root.roughness === 0 && root.face_size === out[0].n) out[0] = bake.crossLevel(0);
  return out;
}
