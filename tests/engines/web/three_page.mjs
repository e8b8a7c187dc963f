// three.js side of the engine proof: loads an environment, renders one
// sphere at a time with an orthographic camera into a float render target
// (no tone mapping) and hands the pixels back.
import * as THREE from 'three';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { f32ToBase64, ready, fail } from '/w/common.mjs';

let renderer, scene, camera, target, size, sphereGeo;
let envTexture = null, pmremGen = null, probe = null, sun = null;

function init(s) {
  size = s;
  const canvas = document.getElementById('c');
  renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: true });
  renderer.setSize(s, s, false);
  renderer.toneMapping = THREE.NoToneMapping;
  renderer.setClearColor(0x000000, 0);
  target = new THREE.WebGLRenderTarget(s, s, { type: THREE.FloatType, format: THREE.RGBAFormat, depthBuffer: true,
                                               minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter });
  scene = new THREE.Scene();
  camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.1, 10);
  camera.position.set(0, 0, 5);
  camera.lookAt(0, 0, 0);
  sphereGeo = new THREE.SphereGeometry(1, 256, 128);
  return { webgl2: renderer.capabilities.isWebGL2 !== false, revision: THREE.REVISION };
}

// The exported KTX2 through the stock KTX2Loader, then its level data
// repacked into a cube (the stock loader makes an uncompressed cube a flat
// 2D texture). Used when the export documents no snippet of its own.
async function loadKtx2Cube(url) {
  const loader = new KTX2Loader().detectSupport(renderer);
  const flat = await loader.loadAsync(url);
  const faces = [0, 1, 2, 3, 4, 5].map((f) => ({
    mipmaps: flat.mipmaps.map((m) => {
      const n = m.data.length / 6;
      return { data: m.data.subarray(f * n, (f + 1) * n), width: m.width, height: m.height };
    }),
    width: flat.image.width, height: flat.image.height,
  }));
  const tex = new THREE.CompressedCubeTexture(faces, flat.format, flat.type);
  tex.minFilter = THREE.LinearMipmapLinearFilter;
  tex.magFilter = THREE.LinearFilter;
  tex.generateMipmaps = false;
  tex.colorSpace = THREE.LinearSRGBColorSpace;
  tex.needsUpdate = true;
  loader.dispose();
  return tex;
}

function setEnv(tex) {
  if (envTexture && envTexture !== tex && envTexture.dispose) envTexture.dispose();
  envTexture = tex;
  scene.environment = tex;
}

const api = {
  init,
  // kind 'ktx2': our export (with the documented snippet when given);
  // kind 'pmrem': three's own PMREMGenerator from the lat-long EXR source.
  async setEnv({ kind, url, snippet }) {
    if (kind === 'ktx2') {
      let tex;
      if (snippet) {
        const mod = await import(snippet);
        tex = await mod.loadIblbakeEnvironment(renderer, url, scene);
      } else {
        tex = await loadKtx2Cube(url);
        tex.isPMREMTexture = true;
      }
      setEnv(tex);
      const mips = tex.isCompressedCubeTexture ? tex.image[0].mipmaps : tex.mipmaps;
      return { levels: mips.length, size: mips[0].width, isPMREMTexture: !!tex.isPMREMTexture,
               isRenderTargetTexture: !!tex.isRenderTargetTexture, type: tex.type };
    }
    if (kind === 'pmrem') {
      const exr = await new EXRLoader().setDataType(THREE.FloatType).loadAsync(url);
      exr.mapping = THREE.EquirectangularReflectionMapping;
      if (!pmremGen) pmremGen = new THREE.PMREMGenerator(renderer);
      const rt = pmremGen.fromEquirectangular(exr);
      exr.dispose();
      setEnv(rt.texture);
      return { levels: rt.texture.mipmaps && rt.texture.mipmaps.length ? rt.texture.mipmaps.length : (rt.texture.image && rt.texture.image.mipmaps ? rt.texture.image.mipmaps.length : null), size: rt.width,
               isPMREMTexture: !!rt.texture.isPMREMTexture, isRenderTargetTexture: !!rt.texture.isRenderTargetTexture };
    }
    if (kind === 'none') { setEnv(null); return {}; }
    throw new Error(`unknown env kind ${kind}`);
  },
  // The sun as a light (issue 27): sun.gltf through the stock GLTFLoader,
  // its DirectionalLight added to the scene as loaded (mirrorX: the same
  // light with its direction's x negated, a deliberately wrong export);
  // null removes it. Returns what was loaded: colour, intensity, direction
  // towards the light (world space), light count.
  async setSun(opts) {
    if (sun) { scene.remove(sun); sun = null; }
    if (!opts) return {};
    const gltf = await new GLTFLoader().loadAsync(opts.url);
    const lights = [];
    gltf.scene.traverse((o) => { if (o.isDirectionalLight) lights.push(o); });
    gltf.scene.updateMatrixWorld(true);
    const light = lights[0];
    const from = light.getWorldPosition(new THREE.Vector3()), to = light.target.getWorldPosition(new THREE.Vector3());
    const dir = from.sub(to).normalize();
    if (opts.mirrorX) {
      const own = new THREE.DirectionalLight(light.color.clone(), light.intensity);
      own.position.set(-dir.x, dir.y, dir.z);
      sun = own;
    } else {
      sun = gltf.scene;
    }
    scene.add(sun);
    return { lights: lights.length, color: light.color.toArray(), intensity: light.intensity, direction: dir.toArray() };
  },
  // The PMREM render target's own levels, read back as float (for the report).
  setProbe(sh9) {
    if (probe) { scene.remove(probe); probe = null; }
    if (!sh9) return;
    const sh = new THREE.SphericalHarmonics3();
    for (let i = 0; i < 9; i++) sh.coefficients[i].set(sh9[0][i], sh9[1][i], sh9[2][i]);
    probe = new THREE.LightProbe(sh, 1);
    scene.add(probe);
  },
  // The normal and the geometry roughness three's physical material
  // computes at each pixel (same expressions as lights_physical_fragment).
  probe() {
    const mat = new THREE.ShaderMaterial({
      vertexShader: `varying vec3 vN; void main() { vN = normalMatrix * normal; gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }`,
      fragmentShader: `varying vec3 vN; void main() {
        vec3 n = normalize(vN);
        vec3 dxy = max(abs(dFdx(n)), abs(dFdy(n)));
        gl_FragColor = vec4(n, max(max(dxy.x, dxy.y), dxy.z)); }`,
    });
    return api._draw(mat);
  },
  _draw(mat) {
    const mesh = new THREE.Mesh(sphereGeo, mat);
    scene.add(mesh);
    renderer.setRenderTarget(target);
    renderer.clear();
    renderer.render(scene, camera);
    const px = new Float32Array(size * size * 4);
    renderer.readRenderTargetPixels(target, 0, 0, size, size, px);
    renderer.setRenderTarget(null);
    scene.remove(mesh);
    mat.dispose();
    return f32ToBase64(px);
  },
  // Orthographic half-size of the view (1: the sphere fills it; small: a
  // close-up of the sphere's centre, where the normal hardly changes per pixel).
  setZoom(h) {
    camera.left = camera.bottom = -h; camera.right = camera.top = h;
    camera.updateProjectionMatrix();
  },
  // One sphere of radius 1 filling the square view (ortho, camera on +Z).
  render({ roughness = 0, metalness = 1, specularIntensity = null, color = 0xffffff }) {
    const mat = specularIntensity === null
      ? new THREE.MeshStandardMaterial({ color, metalness, roughness })
      : new THREE.MeshPhysicalMaterial({ color, metalness, roughness, specularIntensity });
    return api._draw(mat);
  },
};

try { ready(api); } catch (e) { fail(e); }
