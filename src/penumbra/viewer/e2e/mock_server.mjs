#!/usr/bin/env node
// A stand-in for `penumbra view` (docs/viewer.md): serves the page from ../web and a fake
// HTTP API with a synthetic image (a ground plane and a sphere under the light, with a soft
// shadow that follows the light and the camera). It exists so the page can be worked on
// without building penumbra; the e2e test (viewer_e2e.mjs) targets the real server.
//
//   node mock_server.mjs [--port 8421] [--penumbra PATH]   (PATH: take the method list
//                                                            from `PATH methods --json`)
//
// It follows the contract's shapes (state, settings, poll framing, errors) but none of the
// rendering: every method draws the same picture, "refinement" lowers synthetic noise.

import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { execFileSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const webDir = path.join(here, '..', 'web');

const args = process.argv.slice(2);
const argOf = (name, dflt) => { const i = args.indexOf(name); return i >= 0 ? args[i + 1] : dflt; };
let port = Number(argOf('--port', 8421));

// ---- methods ---------------------------------------------------------------------------
let methods = [
  { name: 'reference', description: 'ground truth (mock)', samples_light: true,
    params: [{ name: 'sampling', type: 'string', default: 'solid-angle', doc: 'how light samples are drawn', choices: ['solid-angle', 'area'] }] },
  { name: 'afsm', description: 'sample-based soft visibility (mock)', samples_light: true,
    params: [
      { name: 'resolution', type: 'int', default: 512, doc: 'texels along the light image', choices: [], min: 1, max: 8192 },
      { name: 'max_fov', type: 'float', default: 120.0, doc: 'widest field of view (degrees)', choices: [] },
      { name: 'lut', type: 'bool', default: true, doc: 'look plane masks up in a table', choices: [] }] },
  { name: 'pcss', description: 'percentage-closer soft shadows (mock)', samples_light: false,
    params: [{ name: 'variant', type: 'string', default: 'fernando', doc: 'blocker search variant', choices: ['fernando', 'xie2007'] },
             { name: 'bias', type: 'float', default: 0.002, doc: 'depth bias', choices: [] }] },
  { name: 'lam', description: 'layered attenuation maps (mock)', samples_light: true, params: [] },
  { name: 'occlusion-textures', description: 'occlusion textures (mock)', samples_light: false,
    params: [{ name: 'slices', type: 'int', default: 16, doc: 'slices', choices: [], min: 1, max: 1e300 }] },
];
const penumbra = argOf('--penumbra', null);
if (penumbra) methods = JSON.parse(execFileSync(penumbra, ['methods', '--json'], { encoding: 'utf8' }));
const methodNames = methods.map((m) => m.name);

// ---- state -----------------------------------------------------------------------------
const clone = (x) => JSON.parse(JSON.stringify(x));
const initial = {
  camera: { eye: [0.4, 1.5, 3.0], target: [0, 0.4, 0], up: [0, 1, 0], fov_y: 40, resolution: [512, 512], samples_per_pixel: 1 },
  lights: [{ type: 'rect', center: [-1.2, 3.0, -0.8], normal: [0.4158, -0.8662, 0.2772], u: [1, 0, 0], size: [1.5, 1.5], radiance: [14, 14, 14] }],
};
const view = clone(initial);
let settings = { preview: 'auto', final: 'reference', compare: '', spp: 32, frames: 16, params: {}, preview_scale: 'auto', heatmap_scale: 0.25 };
let generation = 1;
let status = { phase: 'idle', method: '', frame: 0, frames: 0, error: '', cancelled: 0 };
let lightsMovedSinceStill = false;

// ---- synthetic renderer ----------------------------------------------------------------
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => mul(a, 1 / Math.hypot(a[0], a[1], a[2]));
const lightRadius = (l) => l.type === 'rect' ? (l.size[0] + l.size[1]) / 4 : l.type === 'ellipsoid' ? (l.radii[0] + l.radii[1]) / 2 : l.radius;

// V in [0,1] per pixel; `noise` > 0 adds per-frame grain (what refinement removes).
function render(w, h, noise, seed) {
  const cam = view.camera, light = view.lights[0];
  const dir = norm(sub(cam.target, cam.eye)), right = norm(cross(dir, cam.up)), up = cross(right, dir);
  const th = Math.tan((cam.fov_y * Math.PI) / 360), aspect = cam.resolution[0] / cam.resolution[1];
  const sc = [0, 0.4, 0], sr = 0.4; // the "bunny"
  const lc = light.center, lr = lightRadius(light);
  const inten = Math.max(...light.radiance) / 14;
  const px = new Uint8ClampedArray(w * h * 4);
  let rnd = seed * 2654435761 >>> 0;
  for (let y = 0; y < h; y++) {
    for (let x = 0; x < w; x++) {
      const nx = ((x + 0.5) / w) * 2 - 1, ny = 1 - ((y + 0.5) / h) * 2;
      const rd = norm(add(dir, add(mul(right, nx * th * aspect), mul(up, ny * th))));
      let c = [0.05, 0.06, 0.08], p = null, n = null;
      const oc = sub(cam.eye, sc), b = dot(oc, rd), disc = b * b - (dot(oc, oc) - sr * sr);
      if (disc > 0 && -b - Math.sqrt(disc) > 0) { p = add(cam.eye, mul(rd, -b - Math.sqrt(disc))); n = norm(sub(p, sc)); }
      else if (rd[1] < 0) { p = add(cam.eye, mul(rd, -cam.eye[1] / rd[1])); n = [0, 1, 0]; if (Math.abs(p[0]) > 4 || Math.abs(p[2]) > 4) p = null; }
      if (p) {
        const tl = norm(sub(lc, p));
        // soft occlusion: angle between the direction to the light and to the sphere's centre
        const ts = sub(sc, p), dist = Math.hypot(...ts);
        let vis = 1;
        if (n[1] > 0.99 || dot(n, tl) > 0) {
          const cosA = dot(tl, mul(ts, 1 / dist));
          const ang = Math.acos(Math.min(1, Math.max(-1, cosA)));
          const occ = Math.asin(Math.min(1, sr / Math.max(dist, sr))), lang = Math.atan(lr / Math.hypot(...sub(lc, p)));
          if (n[1] <= 0.99) vis = 1; else vis = Math.min(1, Math.max(0, (ang - occ + lang) / (2 * lang)));
        }
        const shade = Math.max(0, dot(n, tl)) * vis * inten;
        const checker = (Math.floor(p[0] * 2) + Math.floor(p[2] * 2)) & 1 ? 0.75 : 0.68;
        const alb = n[1] > 0.99 ? checker : 0.8;
        c = [alb * shade + 0.04, alb * shade * 0.98 + 0.04, alb * shade * 0.94 + 0.05];
      }
      if (noise > 0) { rnd = (rnd * 1664525 + 1013904223) >>> 0; const g = ((rnd / 4294967296) - 0.5) * noise; c = c.map((v) => v + g); }
      const i = (y * w + x) * 4;
      px[i] = 255 * Math.sqrt(Math.max(0, c[0])); px[i + 1] = 255 * Math.sqrt(Math.max(0, c[1])); px[i + 2] = 255 * Math.sqrt(Math.max(0, c[2])); px[i + 3] = 255;
    }
  }
  return px;
}

// ---- frame publication -----------------------------------------------------------------
let seq = 0;
const published = {}; // name -> {seq, meta, pixels}
let waiters = [];
function publish(layers) {
  seq++;
  for (const l of layers) published[l.meta.name] = { seq, meta: l.meta, pixels: l.pixels };
  const ws = waiters; waiters = [];
  for (const w of ws) w();
}
function pollBody(after) {
  const ls = Object.values(published).filter((l) => l.seq > after);
  if (!ls.length) return null;
  let off = 0;
  const metas = ls.map((l) => { const m = { ...l.meta, offset: off }; off += l.pixels.length; return m; });
  const json = Buffer.from(JSON.stringify({ seq, generation, status, layers: metas }));
  const head = Buffer.alloc(4); head.writeUInt32LE(json.length, 0);
  return Buffer.concat([head, json, ...ls.map((l) => Buffer.from(l.pixels.buffer, l.pixels.byteOffset, l.pixels.length))]);
}

let stillTimer = null, refineTimer = null;
function layerMeta(name, w, h, method, kind, frame, frames, ms, extra = {}) {
  const m = methods.find((x) => x.name === method);
  return { name, offset: 0, width: w, height: h, method, kind, frame, frames, ms, light_samples: m && m.samples_light ? settings.spp : 0, generation, mean_dv: null, ...extra };
}
function viewChanged(lightMoved) {
  generation++;
  if (lightMoved) lightsMovedSinceStill = true;
  if (refineTimer) { clearTimeout(refineTimer); refineTimer = null; status.cancelled++; }
  const [W, H] = view.camera.resolution;
  const pm = settings.preview !== 'auto' ? settings.preview : lightsMovedSinceStill ? 'occlusion-textures' : 'lam';
  const scale = settings.preview_scale === 'auto' ? 0.5 : settings.preview_scale;
  const w = Math.max(1, Math.round(W * scale)), h = Math.max(1, Math.round(H * scale));
  status = { ...status, phase: 'preview', method: pm, frame: 0, frames: 0 };
  const t0 = performance.now();
  const px = render(w, h, 0, 1);
  setTimeout(() => publish([{ meta: layerMeta('main', w, h, pm, 'preview', 1, 1, performance.now() - t0), pixels: px }]), 15);
  clearTimeout(stillTimer);
  stillTimer = setTimeout(() => refine(1), 300);
}
function refine(k) {
  lightsMovedSinceStill = false;
  const [W, H] = view.camera.resolution, K = settings.frames;
  status = { ...status, phase: 'refining', method: settings.final, frame: k, frames: K };
  const t0 = performance.now();
  const px = render(W, H, k < K ? 0.3 / Math.sqrt(k) : 0, k); // the last frame equals /api/frame's
  publish([{ meta: layerMeta('main', W, H, settings.final, 'final', k, K, performance.now() - t0), pixels: px }]);
  if (k < K) { refineTimer = setTimeout(() => refine(k + 1), 60); return; }
  refineTimer = null;
  if (!settings.compare) { status = { ...status, phase: 'done' }; return; }
  status = { ...status, phase: 'comparing', method: settings.compare };
  refineTimer = setTimeout(() => {
    const cpx = render(W, H, settings.compare === 'reference' ? 0 : 0.15, 99);
    const dpx = new Uint8ClampedArray(W * H * 4);
    let sum = 0;
    for (let i = 0; i < W * H; i++) {
      const d = Math.abs(px[i * 4] - cpx[i * 4]) / 255; sum += d;
      const t = Math.min(1, d / settings.heatmap_scale);
      dpx[i * 4] = 255 * Math.min(1, t * 1.6); dpx[i * 4 + 1] = 255 * t * t; dpx[i * 4 + 2] = 255 * (0.3 + 0.4 * t); dpx[i * 4 + 3] = 255;
    }
    const mdv = sum / (W * H);
    const heatmap = { lo: 0, hi: settings.heatmap_scale, legend: `magma: black = 0, white = ${settings.heatmap_scale} |ΔV|` };
    status = { ...status, phase: 'done' };
    publish([
      { meta: layerMeta('compare', W, H, settings.compare, 'final', K, K, 5, { mean_dv: mdv }), pixels: cpx },
      { meta: layerMeta('diff', W, H, settings.compare, 'final', K, K, 1, { mean_dv: mdv, heatmap }), pixels: dpx },
    ]);
    refineTimer = null;
  }, 200);
}

// ---- PNG (for /api/frame) --------------------------------------------------------------
const crcTable = Array.from({ length: 256 }, (_, n) => { let c = n; for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1; return c >>> 0; });
const crc32 = (buf) => { let c = 0xffffffff; for (const b of buf) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8); return (c ^ 0xffffffff) >>> 0; };
function chunk(type, data) {
  const len = Buffer.alloc(4); len.writeUInt32BE(data.length);
  const td = Buffer.concat([Buffer.from(type, 'ascii'), data]);
  const crc = Buffer.alloc(4); crc.writeUInt32BE(crc32(td));
  return Buffer.concat([len, td, crc]);
}
function png(w, h, rgba) {
  const ihdr = Buffer.alloc(13); ihdr.writeUInt32BE(w, 0); ihdr.writeUInt32BE(h, 4); ihdr[8] = 8; ihdr[9] = 6;
  const raw = Buffer.alloc((w * 4 + 1) * h);
  for (let y = 0; y < h; y++) Buffer.from(rgba.buffer, rgba.byteOffset + y * w * 4, w * 4).copy(raw, y * (w * 4 + 1) + 1);
  return Buffer.concat([Buffer.from([137, 80, 78, 71, 13, 10, 26, 10]), chunk('IHDR', ihdr), chunk('IDAT', zlib.deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}

// ---- HTTP ------------------------------------------------------------------------------
const fail = (res, code, msg) => { res.writeHead(code, { 'content-type': 'application/json' }); res.end(JSON.stringify({ error: msg })); };
const ok = (res, obj) => { res.writeHead(200, { 'content-type': 'application/json' }); res.end(JSON.stringify(obj)); };
const readBody = (req) => new Promise((resolve) => { let s = ''; req.on('data', (d) => { s += d; }); req.on('end', () => resolve(s)); });
const sceneDoc = () => ({ description: 'mock scene', camera: view.camera, lights: view.lights, objects: [], methods: {} });

function mergePatch(target, patch) {
  if (patch === null || typeof patch !== 'object' || Array.isArray(patch)) return clone(patch);
  const out = target && typeof target === 'object' && !Array.isArray(target) ? clone(target) : {};
  for (const [k, v] of Object.entries(patch)) { if (v === null) delete out[k]; else out[k] = mergePatch(out[k], v); }
  return out;
}

function applySettings(body) {
  const next = clone(settings);
  for (const [k, v] of Object.entries(body)) {
    if (!(k in next)) throw new Error(`settings: unknown key "${k}"`);
    if (['preview', 'final', 'compare'].includes(k)) {
      if (!(v === '' && k === 'compare') && !(v === 'auto' && k === 'preview') && !methodNames.includes(v)) throw new Error(`${k}: unknown method "${v}"`);
      next[k] = v;
    } else if (k === 'spp' || k === 'frames') {
      if (!Number.isInteger(v) || v < 1 || v > 4096) throw new Error(`${k}: must be an integer in [1, 4096], got ${JSON.stringify(v)}`);
      next[k] = v;
    } else if (k === 'params') {
      for (const [mn, ps] of Object.entries(v)) {
        const m = methods.find((x) => x.name === mn);
        if (!m) throw new Error(`params: unknown method "${mn}"`);
        for (const [pk, pv] of Object.entries(ps)) {
          const p = m.params.find((x) => x.name === pk);
          if (!p) throw new Error(`${mn}: unknown parameter "${pk}"`);
          if ((p.type === 'int' || p.type === 'float') && (typeof pv !== 'number' || (p.type === 'int' && !Number.isInteger(pv)) || pv <= 0))
            throw new Error(`${mn}: ${pk} must be a positive ${p.type}, got ${JSON.stringify(pv)}`);
          if (p.type === 'bool' && typeof pv !== 'boolean') throw new Error(`${mn}: ${pk} must be true or false`);
          if (p.type === 'string' && p.choices.length && !p.choices.includes(pv)) throw new Error(`${mn}: ${pk} must be one of ${p.choices.join(', ')}`);
          next.params[mn] = { ...(next.params[mn] || {}), [pk]: pv };
        }
      }
    } else next[k] = v;
  }
  return next;
}

const mime = { '.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8', '.css': 'text/css; charset=utf-8' };
const server = http.createServer(async (req, res) => {
  const url = new URL(req.url, 'http://localhost');
  const p = url.pathname;
  try {
    if (req.method === 'GET' && (p === '/' || p === '/viewer.js' || p === '/viewer.css')) {
      const f = path.join(webDir, p === '/' ? 'index.html' : p.slice(1));
      res.writeHead(200, { 'content-type': mime[path.extname(f)], 'cache-control': 'no-store' });
      res.end(fs.readFileSync(f));
    } else if (p === '/api/methods') ok(res, methods);
    else if (p === '/api/scene') ok(res, sceneDoc());
    else if (p === '/api/scene-file') {
      res.writeHead(200, { 'content-type': 'application/json', 'content-disposition': 'attachment; filename="VIEW.json"' });
      res.end(JSON.stringify(sceneDoc(), null, 2));
    } else if (p === '/api/state') {
      ok(res, { generation, camera: view.camera, lights: view.lights, bounds: { min: [-4, 0, -4], max: [4, 0.99, 4] }, initial, settings, status });
    } else if (p === '/api/poll') {
      const after = Number(url.searchParams.get('after') || 0);
      const timeout = Math.min(30000, Number(url.searchParams.get('timeout_ms') || 10000));
      let body = pollBody(after);
      if (!body) {
        await new Promise((resolve) => { const t = setTimeout(resolve, timeout); waiters.push(() => { clearTimeout(t); resolve(); }); });
        body = pollBody(after);
      }
      if (!body) { res.writeHead(204); res.end(); return; }
      res.writeHead(200, { 'content-type': 'application/octet-stream' }); res.end(body);
    } else if (p === '/api/frame') {
      const [W, H] = view.camera.resolution;
      if ((url.searchParams.get('format') || 'png') !== 'png') return fail(res, 400, 'format: the mock writes png only');
      res.writeHead(200, { 'content-type': 'image/png' }); res.end(png(W, H, render(W, H, 0, 1)));
    } else if (req.method !== 'POST') fail(res, p.startsWith('/api/') ? 405 : 404, `${req.method} ${p}: not found`);
    else {
      const text = await readBody(req);
      let body = {};
      if (text) { try { body = JSON.parse(text); } catch (e) { return fail(res, 400, `${p}: ${e.message}`); } }
      if (p === '/api/view') {
        for (const k of Object.keys(body)) if (k !== 'camera' && k !== 'lights') return fail(res, 400, `POST /api/view: unknown key "${k}"`);
        if (body.lights) for (const l of body.lights) {
          const allowed = { rect: ['type', 'center', 'normal', 'u', 'size', 'radiance'], disk: ['type', 'center', 'normal', 'u', 'radius', 'radiance'],
                            sphere: ['type', 'center', 'radius', 'radiance'], ellipsoid: ['type', 'center', 'normal', 'u', 'radii', 'radiance'] }[l.type];
          if (!allowed) return fail(res, 400, `lights: unknown type "${l.type}"`);
          for (const k of Object.keys(l)) if (!allowed.includes(k)) return fail(res, 400, `lights: unknown key "${k}" for a ${l.type} light`);
        }
        const camMoved = !!body.camera, lightMoved = !!body.lights;
        if (body.camera) view.camera = mergePatch(view.camera, body.camera);
        if (body.lights) view.lights = clone(body.lights);
        viewChanged(lightMoved && !camMoved || lightMoved);
        ok(res, { generation });
      } else if (p === '/api/settings') {
        settings = applySettings(body);
        viewChanged(false);
        ok(res, settings);
      } else if (p === '/api/refine') { clearTimeout(stillTimer); generation++; refine(1); ok(res, { generation }); }
      else if (p === '/api/reset') { view.camera = clone(initial.camera); view.lights = clone(initial.lights); viewChanged(true); ok(res, { generation }); }
      else fail(res, 404, `POST ${p}: not found`);
    }
  } catch (e) { fail(res, 400, e.message); }
});

// The next free port, as the real server does.
server.on('error', (e) => { if (e.code === 'EADDRINUSE') { port++; server.listen(port, '127.0.0.1'); } else throw e; });
server.on('listening', () => { console.log(`penumbra view: serving http://127.0.0.1:${port}/`); viewChanged(false); });
server.listen(port, '127.0.0.1');
