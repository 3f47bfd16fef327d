// Renders data/default's glTF in a real engine (three.js or Babylon.js) inside headless Debian
// chromium (WebGL2 on SwiftShader), with the camera and lights `penumbra camera` printed, and
// writes the engine's shadow term and its linear view depth for `penumbra compare`.
// Usage: node render.mjs ENGINE CAMERA_JSON SCENE_GLB CONFIGS_JSON OUT_DIR
//   CONFIGS_JSON: [{"name": "...", "light": 0, "mapSize": 1024, ...engine settings}]
//   writes OUT_DIR/<name>.shadow.pfm and OUT_DIR/<name>.depth.pfm (float, one channel) and
//   OUT_DIR/<name>.json ({"note": what was drawn, "bias_m": the biases as metres along the light,
//   "texel_m": a directional map's texel in metres})
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import puppeteer from 'puppeteer-core';

const [engine, cameraFile, sceneFile, configsFile, outDir] = process.argv.slice(2);
if (!outDir) {
    console.error('usage: node render.mjs three|babylon CAMERA_JSON SCENE_GLB CONFIGS_JSON OUT_DIR');
    process.exit(2);
}
const here = path.dirname(fileURLToPath(import.meta.url));
const kit = JSON.parse(fs.readFileSync(cameraFile, 'utf8'));
const configs = JSON.parse(fs.readFileSync(configsFile, 'utf8'));
fs.mkdirSync(outDir, { recursive: true });

// PFM (Portable Float Map): one channel, little-endian, rows from the bottom up (the format's
// own order); `rows` is top-first, as penumbra's images are.
function writePfm(file, w, h, rows) {
    const header = Buffer.from(`Pf\n${w} ${h}\n-1.0\n`, 'ascii');
    const body = Buffer.alloc(w * h * 4);
    for (let y = 0; y < h; ++y)
        for (let x = 0; x < w; ++x) body.writeFloatLE(rows[(h - 1 - y) * w + x], 4 * (y * w + x));
    fs.writeFileSync(file, Buffer.concat([header, body]));
}

// Serves the engine pages, node_modules and the scene on a loopback port.
const types = { '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript', '.glb': 'model/gltf-binary' };
const server = http.createServer((req, res) => {
    const url = decodeURIComponent(req.url.split('?')[0]);
    const file = url === '/scene.glb' ? sceneFile : path.join(here, path.normalize(url));
    if (url !== '/scene.glb' && !file.startsWith(here)) return res.writeHead(403).end();
    fs.readFile(file, (err, data) => {
        if (err) return res.writeHead(404).end();
        res.writeHead(200, { 'Content-Type': types[path.extname(file)] || 'application/octet-stream' }).end(data);
    });
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const port = server.address().port;

const browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
});
let failed = false;
try {
    const page = await browser.newPage();
    page.on('console', (m) => { if (m.type() === 'error') console.error(`${engine} page: ${m.text()}`); });
    page.on('pageerror', (e) => { console.error(`${engine} page: ${e.message}`); failed = true; });
    await page.goto(`http://127.0.0.1:${port}/${engine}.html`);
    await page.waitForFunction('window.renderFrame !== undefined', { timeout: 30000 });
    for (const cfg of configs) {
        const r = await page.evaluate((k, c) => window.renderFrame(k, '/scene.glb', c), kit, cfg);
        writePfm(path.join(outDir, `${cfg.name}.shadow.pfm`), r.width, r.height, r.shadow);
        writePfm(path.join(outDir, `${cfg.name}.depth.pfm`), r.width, r.height, r.depth);
        // What the page says it drew, its biases as metres along the light (compare's --bias-m)
        // and, for a directional light, its map's texel in metres (--texel-m).
        fs.writeFileSync(path.join(outDir, `${cfg.name}.json`),
                         JSON.stringify({ note: r.note, bias_m: r.biasM, texel_m: r.texelM }));
        console.log(`${engine}: ${cfg.name}: ${r.width}x${r.height}, ${r.note}`);
    }
} catch (e) {
    console.error(`${engine}: ${e.message}`);
    failed = true;
} finally {
    await browser.close();
    server.close();
}
process.exit(failed ? 1 : 0);
