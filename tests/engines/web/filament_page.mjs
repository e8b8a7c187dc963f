// Filament (WASM) side of the engine proof.
import { f32ToBase64, ready, fail } from '/w/common.mjs';

let F, engine, scene, renderer, swapChain, view, camera, gl, size, loader, asset = null, ibl = null, iblTex = null;

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
  return new Uint8Array(await r.arrayBuffer());
}

function init(s) {
  size = s;
  const canvas = document.getElementById('c');
  canvas.width = canvas.height = s;
  // The context Filament will get (same attributes as Engine.create's), with a
  // half-float drawing buffer so the frame can be read back unclamped.
  gl = canvas.getContext('webgl2', { majorVersion: 2, minorVersion: 0, antialias: false, depth: true, alpha: true,
                                     preserveDrawingBuffer: true });
  let floatBuffer = false;
  gl.getExtension('EXT_color_buffer_float');
  gl.getExtension('EXT_color_buffer_half_float');
  if (gl.drawingBufferStorage) { gl.drawingBufferStorage(gl.RGBA16F, s, s); floatBuffer = gl.drawingBufferFormat === gl.RGBA16F; }
  engine = F.Engine.create(canvas, { alpha: true, preserveDrawingBuffer: true });
  scene = engine.createScene();
  swapChain = engine.createSwapChain();
  renderer = engine.createRenderer();
  renderer.setClearOptions({ clearColor: [0, 0, 0, 0], clear: true });
  camera = engine.createCamera(F.EntityManager.get().create());
  camera.setProjection(F.Camera$Projection.ORTHO, -1, 1, -1, 1, 0.1, 10);
  camera.lookAt([0, 0, 5], [0, 0, 0], [0, 1, 0]);
  camera.setExposureDirect(1.0);
  view = engine.createView();
  view.setCamera(camera);
  view.setScene(scene);
  view.setViewport([0, 0, s, s]);
  view.setPostProcessingEnabled(false);
  loader = engine.createAssetLoader();
  return { floatBuffer, drawingBufferFormat: gl.drawingBufferFormat };
}

let ktxIbl = null, shIbl = null, reflections = null;

function useIbl(light) {
  scene.setIndirectLight(light);
}

const api = {
  init,
  // The preset's file through Filament's own KTX1 path (createIblFromKtx1: reflections + the `sh` key).
  async setIblKtx1(url) {
    const bytes = await fetchBytes(url);
    if (shIbl) { engine.destroyIndirectLight(shIbl); shIbl = null; }
    if (ktxIbl) { scene.setIndirectLight(null); engine.destroyIndirectLight(ktxIbl); engine.destroyTexture(reflections); }
    ktxIbl = engine.createIblFromKtx1(bytes);
    ktxIbl.setIntensity(1.0);
    reflections = ktxIbl.getReflectionsTexture();
    useIbl(ktxIbl);
    return { sh: ktxIbl.shfloats ? Array.from(ktxIbl.shfloats) : null };
  },
  // The same reflections with other SH (27 floats, band by band, rgb), or the KTX's own (null).
  setSh(sh) {
    if (shIbl) { engine.destroyIndirectLight(shIbl); shIbl = null; }
    if (!sh) { useIbl(ktxIbl); return; }
    shIbl = F.IndirectLight.Builder().reflections(reflections).irradianceSh(3, Float32Array.from(sh)).intensity(1.0).build(engine);
    useIbl(shIbl);
  },
  async setSphere(url) {
    if (asset) { scene.removeEntities(asset.getEntities()); loader.destroyAsset(asset); }
    asset = loader.createAsset(await fetchBytes(url));
    await new Promise((res) => asset.loadResources(res, null, null, null));
    scene.addEntities(asset.getEntities());
    return { entities: asset.getEntities().length };
  },
  async render({ roughness = 0, metallic = 1, baseColor = [1, 1, 1, 1], specularAA = true } = {}) {
    const rm = engine.getRenderableManager();
    for (const e of asset.getRenderableEntities()) {
      const inst = rm.getInstance(e);
      const mi = rm.getMaterialInstanceAt(inst, 0);
      mi.setFloatParameter('roughnessFactor', roughness);
      mi.setFloatParameter('metallicFactor', metallic);
      mi.setFloat4Parameter('baseColorFactor', baseColor);
      // gltfio's materials filter roughness by the normal's screen derivatives
      // (geometric specular anti-aliasing, variance 0.15 by default).
      mi.setSpecularAntiAliasingVariance(specularAA ? 0.15 : 0.0);
      inst.delete();
    }
    let frames = 0;
    for (let k = 0; k < 20 && frames < 2; k++) {
      if (renderer.beginFrame(swapChain)) { renderer.renderView(view); renderer.endFrame(); frames++; }
      engine.execute();
      await new Promise((r) => setTimeout(r, 5));
    }
    gl.finish();
    const px = new Float32Array(size * size * 4);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
    gl.readPixels(0, 0, size, size, gl.RGBA, gl.FLOAT, px);
    const err = gl.getError();
    if (err) throw new Error(`readPixels: GL error ${err}`);
    if (frames < 2) throw new Error(`Filament rendered ${frames} frames`);
    return f32ToBase64(px);
  },
};

// Filament.init replaces the global factory with the module: read it after.
window.Filament.init([], () => { try { F = window.Filament; ready(api); } catch (e) { fail(e); } });
