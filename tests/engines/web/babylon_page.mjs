// Babylon.js side of the engine proof. Babylon's world is left-handed; a
// glTF (right-handed) scene is imported with Z negated, so the camera sits
// on -Z looking toward +Z: the same view of the world as three.js's camera
// on +Z of a right-handed scene.
import { Engine } from '@babylonjs/core/Engines/engine.js';
import { Scene } from '@babylonjs/core/scene.js';
import { FreeCamera } from '@babylonjs/core/Cameras/freeCamera.js';
import { Camera } from '@babylonjs/core/Cameras/camera.js';
import { Vector3 } from '@babylonjs/core/Maths/math.vector.js';
import { Color4, Color3 } from '@babylonjs/core/Maths/math.color.js';
import { CreateSphere } from '@babylonjs/core/Meshes/Builders/sphereBuilder.js';
import { PBRMaterial } from '@babylonjs/core/Materials/PBR/pbrMaterial.js';
import { CubeTexture } from '@babylonjs/core/Materials/Textures/cubeTexture.js';
import { EXRCubeTexture } from '@babylonjs/core/Materials/Textures/exrCubeTexture.js';
import '@babylonjs/core/Materials/Textures/Loaders/envTextureLoader.js';
import { ExrLoaderGlobalConfiguration } from '@babylonjs/core/Materials/Textures/Loaders/EXR/exrLoader.configuration.js';
import { f32ToBase64, ready, fail } from '/w/common.mjs';

// Babylon's EXR reader fetches fflate from a CDN by default: serve the pinned copy.
ExrLoaderGlobalConfiguration.FFLATEUrl = '/m/fflate/umd/index.js';

let engine, scene, camera, gl, size, sphere = null, env = null;

function init(s) {
  size = s;
  const canvas = document.getElementById('c');
  canvas.width = canvas.height = s;
  gl = canvas.getContext('webgl2', { antialias: false, alpha: true, premultipliedAlpha: false, preserveDrawingBuffer: true,
                                     depth: true, stencil: true });
  gl.getExtension('EXT_color_buffer_float');
  gl.getExtension('EXT_color_buffer_half_float');
  gl.drawingBufferStorage(gl.RGBA16F, s, s);
  engine = new Engine(canvas, false, { preserveDrawingBuffer: true, alpha: true, premultipliedAlpha: false, stencil: true,
                                       antialias: false, adaptToDeviceRatio: false });
  scene = new Scene(engine);
  scene.clearColor = new Color4(0, 0, 0, 0);
  scene.imageProcessingConfiguration.applyByPostProcess = true;   // linear output, no tone map, no gamma
  camera = new FreeCamera('cam', new Vector3(0, 0, -5), scene);
  camera.setTarget(Vector3.Zero());
  camera.mode = Camera.ORTHOGRAPHIC_CAMERA;
  camera.orthoLeft = -1; camera.orthoRight = 1; camera.orthoTop = 1; camera.orthoBottom = -1;
  camera.minZ = 0.1; camera.maxZ = 10;
  return { drawingBufferFormat: gl.drawingBufferFormat, float: gl.drawingBufferFormat === gl.RGBA16F, version: Engine.Version };
}

function waitReady(tex) {
  return new Promise((res, rej) => {
    const t0 = performance.now();
    const poll = () => {
      if (tex.isReady()) res();
      else if (performance.now() - t0 > 120000) rej(new Error('environment texture never became ready'));
      else setTimeout(poll, 20);
    };
    poll();
  });
}

const api = {
  init,
  // kind 'env': our .env; kind 'exr': Babylon's own prefiltering of the lat-long EXR.
  async setEnv({ kind, url, size: cubeSize = 256 }) {
    if (env) env.dispose();
    if (kind === 'env') env = CubeTexture.CreateFromPrefilteredData(url, scene);
    else if (kind === 'exr') env = new EXRCubeTexture(url, scene, cubeSize, false, true, false, true);
    else throw new Error(`unknown env kind ${kind}`);
    await waitReady(env);
    scene.environmentTexture = env;
    const sp = env.sphericalPolynomial;
    return { lodGenerationScale: env.lodGenerationScale, lodGenerationOffset: env.lodGenerationOffset,
             size: env.getSize().width, levels: env._texture ? env._texture.mipLevelCount : null,
             polynomial: sp ? { x: sp.x.asArray(), y: sp.y.asArray(), z: sp.z.asArray(), xx: sp.xx.asArray(), yy: sp.yy.asArray(),
                                zz: sp.zz.asArray(), xy: sp.xy.asArray(), yz: sp.yz.asArray(), zx: sp.zx.asArray() } : null };
  },
  async render({ roughness = 0, metallic = 1, diffuse = false }) {
    if (!sphere) sphere = CreateSphere('s', { diameter: 2, segments: 128 }, scene);
    const mat = new PBRMaterial('m', scene);
    mat.albedoColor = new Color3(1, 1, 1);
    mat.metallic = diffuse ? 0 : metallic;
    mat.roughness = roughness;
    if (diffuse) { mat.metallicF0Factor = 0; }
    sphere.material = mat;
    await scene.whenReadyAsync();
    scene.render();
    gl.finish();
    const px = new Float32Array(size * size * 4);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
    gl.readPixels(0, 0, size, size, gl.RGBA, gl.FLOAT, px);
    mat.dispose();
    return { glError: gl.getError(), pixels: f32ToBase64(px) };
  },
};

try { ready(api); } catch (e) { fail(e); }
