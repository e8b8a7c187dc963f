// Shared by the engine pages: float pixels to base64 for page.evaluate.
export function f32ToBase64(arr) {
  const bytes = new Uint8Array(arr.buffer, arr.byteOffset, arr.byteLength);
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}
export function ready(api) {
  window.iblTest = api;
  window.__ready = true;
}
export function fail(e) {
  window.__error = String(e && e.stack ? e.stack : e);
}
