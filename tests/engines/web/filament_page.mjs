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

const api = {
  init,
  async setIblKtx1(url) {
    const bytes = await fetchBytes(url);
    if (ibl) { scene.setIndirectLight(null); engine.destroyIndirectLight(ibl); engine.destroyTexture(iblTex); }
    ibl = engine.createIblFromKtx1(bytes);
    ibl.setIntensity(1.0);
    iblTex = ibl.getReflectionsTexture();
    scene.setIndirectLight(ibl);
    return { sh: ibl.shfloats ? Array.from(ibl.shfloats) : null };
  },
  async setSphere(url) {
    if (asset) { scene.removeEntities(asset.getEntities()); loader.destroyAsset(asset); }
    asset = loader.createAsset(await fetchBytes(url));
    await new Promise((res) => asset.loadResources(res, null, null, null));
    scene.addEntities(asset.getEntities());
    return { entities: asset.getEntities().length };
  },
  async render() {
    let frames = 0;
    for (let k = 0; k < 10; k++) {
      if (renderer.beginFrame(swapChain)) { renderer.renderView(view); renderer.endFrame(); frames++; }
      engine.execute();
      await new Promise((r) => setTimeout(r, 10));
      if (frames >= 2) break;
    }
    gl.finish();
    const px = new Float32Array(size * size * 4);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
    gl.readPixels(0, 0, size, size, gl.RGBA, gl.FLOAT, px);
    return { frames, glError: gl.getError(), pixels: f32ToBase64(px) };
  },
};

// Filament.init replaces the global factory with the module: read it after.
window.Filament.init([], () => { try { F = window.Filament; ready(api); } catch (e) { fail(e); } });
