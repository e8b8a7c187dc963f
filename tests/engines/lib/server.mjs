// A static file server on 127.0.0.1 (ephemeral port) for the engine pages.
// Mounts: each URL prefix maps to one folder; nothing outside them is served.
import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';

const TYPES = {
  '.html': 'text/html; charset=utf-8', '.js': 'text/javascript', '.mjs': 'text/javascript',
  '.json': 'application/json', '.wasm': 'application/wasm', '.png': 'image/png',
  '.ktx': 'application/octet-stream', '.ktx2': 'image/ktx2', '.env': 'application/octet-stream',
  '.dds': 'application/octet-stream', '.exr': 'application/octet-stream', '.glb': 'model/gltf-binary',
};

// mounts: { '/m/': '/abs/node_modules', '/w/': '/abs/web', ... }
export async function startServer(mounts) {
  const entries = Object.entries(mounts).map(([p, d]) => [p, path.resolve(d)]);
  const server = http.createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://127.0.0.1').pathname);
    for (const [prefix, dir] of entries) {
      if (!url.startsWith(prefix)) continue;
      const file = path.resolve(dir, '.' + url.slice(prefix.length - 1));
      if (file !== dir && !file.startsWith(dir + path.sep)) break;
      fs.stat(file, (err, st) => {
        if (err || !st.isFile()) { res.writeHead(404); res.end('not found: ' + url); return; }
        res.writeHead(200, { 'Content-Type': TYPES[path.extname(file)] || 'application/octet-stream',
                             'Content-Length': st.size, 'Cache-Control': 'no-store' });
        fs.createReadStream(file).pipe(res);
      });
      return;
    }
    res.writeHead(404); res.end('not found: ' + url);
  });
  await new Promise((resolve, reject) => { server.once('error', reject); server.listen(0, '127.0.0.1', resolve); });
  const { port } = server.address();
  return { url: `http://127.0.0.1:${port}`, close: () => new Promise((r) => server.close(r)) };
}
