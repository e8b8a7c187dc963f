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
import { ShaderMaterial } from '@babylonjs/core/Materials/shaderMaterial.js';
import { CubeTexture } from '@babylonjs/core/Materials/Textures/cubeTexture.js';
import { SphericalPolynomial } from '@babylonjs/core/Maths/sphericalPolynomial.js';
import { EXRCubeTexture } from '@babylonjs/core/Materials/Textures/exrCubeTexture.js';
import '@babylonjs/core/Materials/Textures/Loaders/envTextureLoader.js';
import { RawCubeTexture } from '@babylonjs/core/Materials/Textures/rawCubeTexture.js';
import { CreateEnvTextureAsync } from '@babylonjs/core/Misc/environmentTextureTools.js';
import { ExrLoaderGlobalConfiguration } from '@babylonjs/core/Materials/Textures/Loaders/EXR/exrLoader.configuration.js';
import { DirectionalLight } from '@babylonjs/core/Lights/directionalLight.js';
import { LoadAssetContainerAsync } from '@babylonjs/core/Loading/sceneLoader.js';
import '@babylonjs/loaders/glTF/index.js';   // the glTF file loader and its extensions (KHR_lights_punctual)
import { f32ToBase64, ready, fail } from '/w/common.mjs';

// Babylon's EXR reader fetches fflate from a CDN by default: serve the pinned copy.
ExrLoaderGlobalConfiguration.FFLATEUrl = '/m/fflate/umd/index.js';

let engine, scene, camera, gl, size, sphere = null, env = null, sunAsset = null, ownLight = null;

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
  camera = new FreeCamera('cam', new Vector3(0, 0, 5), scene);  // sees SPEC's +Z side, as three.js's camera
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

// One frame of the scene, read back from the RGBA16F drawing buffer as float.
async function renderAndRead() {
  await scene.whenReadyAsync();
  scene.render();
  gl.finish();
  const px = new Float32Array(size * size * 4);
  gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
  gl.readPixels(0, 0, size, size, gl.RGBA, gl.FLOAT, px);
  return px;
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
  // Loads a glTF (sun.gltf) with Babylon's glTF loader into the scene (null: removes it).
  // Reports every light the scene then holds, and for the directional ones the
  // world direction of travel: the light's own direction through its node's
  // world matrix (the loader's __root__ turns glTF's right-handed space into
  // Babylon's left-handed one), beside Babylon's own transformedDirection.
  async setSun(opts) {
    if (sunAsset) { sunAsset.removeAllFromScene(); sunAsset.dispose(); sunAsset = null; }
    if (!opts) return {};
    sunAsset = await LoadAssetContainerAsync(opts.url, scene);
    sunAsset.addAllToScene();
    const out = [];
    for (const l of scene.lights) {
      const chain = [];
      for (let n = l.parent; n; n = n.parent) chain.unshift(n);
      chain.forEach((n) => n.computeWorldMatrix(true));
      const item = { name: l.name, className: l.getClassName(), isDirectional: l instanceof DirectionalLight, enabled: l.isEnabled(),
                     parents: chain.map((n) => n.name), intensity: l.intensity, intensityMode: l.intensityMode, photometricScale: l._photometricScale,
                     diffuse: l.diffuse.asArray(), specular: l.specular.asArray(), direction: l.direction ? l.direction.asArray() : null };
      if (item.isDirectional) {
        const wm = chain.length ? chain[chain.length - 1].getWorldMatrix() : null;
        item.worldDirection = (wm ? Vector3.TransformNormal(l.direction, wm) : l.direction.clone()).normalize().asArray();
        l.computeTransformedInformation();
        item.transformedDirection = l.transformedDirection ? l.transformedDirection.clone().normalize().asArray() : null;
        if (chain.length) {
          const root = chain[0];
          item.root = { name: root.name, rotation: root.rotationQuaternion ? root.rotationQuaternion.asArray() : null, scaling: root.scaling.asArray() };
        }
      }
      out.push(item);
    }
    return { lights: out };
  },
  // A DirectionalLight made by hand (sun.json's api: direction of travel, diffuse = colour), or none (null).
  setLight(o) {
    if (ownLight) { ownLight.dispose(); ownLight = null; }
    if (!o) return;
    ownLight = new DirectionalLight('own_sun', new Vector3(...o.direction), scene);
    ownLight.diffuse = new Color3(...o.color);
    ownLight.intensity = o.intensity;
  },
  // Replaces the environment's irradiance polynomial ({x, y, z, xx, ...} of [r, g, b]), or restores the file's (null).
  setPolynomial(p) {
    if (!env._filePolynomial) env._filePolynomial = env.sphericalPolynomial;
    if (!p) { env.sphericalPolynomial = env._filePolynomial; return; }
    env.sphericalPolynomial = SphericalPolynomial.FromArray([p.x, p.y, p.z, p.xx, p.yy, p.zz, p.yz, p.zx, p.xy]);
  },
  info() {
    const mat = sphere && sphere.material;
    return { defines: mat ? String(mat.getEffect()?.defines || '') : null, lodLevelInAlpha: env?.lodLevelInAlpha, linearSpecularLOD: env?.linearSpecularLOD,
             gammaSpace: env?.gammaSpace, isRGBD: env?.isRGBD, invertZ: env?.invertZ, texType: env?._texture?.type };
  },
  // Babylon's own .env writer on a cube uploaded in GL order (row 0 = t = 0):
  // face f texel (i, j) = (i + 0.5) / n, (j + 0.5) / n, f / 8. Returns the .env bytes.
  async ownEnv(n) {
    const faces = [];
    for (let f = 0; f < 6; f++) {
      const d = new Float32Array(n * n * 4);
      for (let j = 0; j < n; j++) for (let i = 0; i < n; i++) d.set([(i + 0.5) / n, (j + 0.5) / n, (f + 1) / 8, 1], (j * n + i) * 4);
      faces.push(d);
    }
    const tex = new RawCubeTexture(scene, faces, n, 5, 1, true, false, 3);
    await waitReady(tex);
    const buf = await CreateEnvTextureAsync(tex, { imageType: 'image/png' });
    tex.dispose();
    return f32ToBase64(new Uint8Array(buf));
  },
  // World normal (rgb) and world z of the surface (a) at each pixel, as Babylon interpolates them.
  async probe() {
    if (!sphere) sphere = CreateSphere('s', { diameter: 2, segments: 128 }, scene);
    const mat = new ShaderMaterial('probe', scene, {
      vertexSource: `precision highp float; attribute vec3 position; attribute vec3 normal; uniform mat4 world; uniform mat4 worldViewProjection;
        varying vec3 vN; varying vec3 vP; void main() { vN = mat3(world) * normal; vP = (world * vec4(position, 1.0)).xyz; gl_Position = worldViewProjection * vec4(position, 1.0); }`,
      fragmentSource: `precision highp float; varying vec3 vN; varying vec3 vP; void main() { gl_FragColor = vec4(normalize(vN), vP.z); }`,
    }, { attributes: ['position', 'normal'], uniforms: ['world', 'worldViewProjection'] });
    sphere.material = mat;
    const px = await renderAndRead();
    mat.dispose();
    return f32ToBase64(px);
  },
  async render({ roughness = 0, metallic = 1, diffuse = false }) {
    if (!sphere) sphere = CreateSphere('s', { diameter: 2, segments: 128 }, scene);
    const mat = new PBRMaterial('m', scene);
    mat.albedoColor = new Color3(1, 1, 1);
    mat.metallic = diffuse ? 0 : metallic;
    mat.roughness = roughness;
    if (diffuse) { mat.metallicF0Factor = 0; }
    sphere.material = mat;
    const px = await renderAndRead();
    const defines = String(mat.getEffect()?.defines || '');
    mat.dispose();
    return { glError: gl.getError(), pixels: f32ToBase64(px), defines };
  },
};

try { ready(api); } catch (e) { fail(e); }
