// penumbra view: the page (docs/viewer.md). Everything goes through the HTTP API:
//   - a long-poll loop receives frames (GET /api/poll) and draws the `main` layer,
//     or `main` | `compare` split, or the `diff` heat map;
//   - navigation and the light handle send the view (POST /api/view), coalesced so that at
//     most one request is in flight and only the newest pending state follows it;
//   - the side panel edits settings (POST /api/settings) and the light.
// window.penumbraViewer exposes the state for scripts and the end-to-end test
// (src/penumbra/viewer/e2e/viewer_e2e.mjs).
'use strict';

(() => {
  // ---- small vector helpers (arrays of 3 numbers) ----------------------------------------
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const len = (a) => Math.hypot(a[0], a[1], a[2]);
  const normalize = (a) => { const l = len(a); return l > 0 ? scale(a, 1 / l) : [0, 0, 0]; };
  // Rodrigues: v rotated by `angle` around the unit axis k.
  const rotate = (v, k, angle) => {
    const c = Math.cos(angle), s = Math.sin(angle);
    return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
  };
  const clone = (x) => JSON.parse(JSON.stringify(x));
  // Deep equality with a tolerance on numbers (what we sent was rounded by tidy()).
  const near = (a, b) => {
    if (typeof a === 'number' && typeof b === 'number') return Math.abs(a - b) <= 1e-5 * Math.max(1, Math.abs(a));
    if (Array.isArray(a) && Array.isArray(b)) return a.length === b.length && a.every((x, i) => near(x, b[i]));
    if (a && b && typeof a === 'object' && typeof b === 'object') {
      const ka = Object.keys(a), kb = Object.keys(b);
      return ka.length === kb.length && ka.every((k) => near(a[k], b[k]));
    }
    return a === b;
  };
  // Scene-file numbers: round away float noise so saved scene files stay readable.
  const tidy = (v) => v.map((x) => Math.round(x * 1e6) / 1e6);
  const $ = (id) => document.getElementById(id);
  const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

  // ---- the public state (scripts and the e2e test read it) -------------------------------
  const V = {
    state: null,        // last GET /api/state answer
    methods: [],        // GET /api/methods
    device: null,       // GET /api/state .device: where the frames render
    layers: {},         // name -> the last layer metadata received (with the message's seq)
    frameCount: 0,      // main frames drawn
    lastMainFrame: null,
    lastLightMoveAt: 0, // performance.now() of the last light-handle move that sent a view
    lightHandle: (i) => {
      const el = handles[i];
      if (!el) return null;
      const r = el.getBoundingClientRect();
      return { x: r.left + r.width / 2, y: r.top + r.height / 2 }; // viewport CSS px (the page never scrolls)
    },
    canvasPixels: () => {
      const img = images.main && images.main.imageData;
      if (!img) return null;
      return { width: img.width, height: img.height, data: Array.from(img.data) };
    },
  };
  window.penumbraViewer = V;

  // name -> {meta, imageData, canvas}: the last image per layer at its own resolution.
  const images = {};
  // The view as this page knows it: what it last sent, so interaction never waits for the server.
  let camera = null, lights = [];
  let settings = null;
  let sceneMethods = {};     // the scene file's "methods" table (defaults under settings.params)
  let diag = 1;              // the scene bounds' diagonal: slider ranges scale with it
  let selected = 0;          // the light the panel edits
  let viewMode = 'main';     // 'main' | 'split' | 'diff'
  let splitX = 0.5;          // split line, as a fraction of the canvas width
  let myGeneration = 0;      // newest generation our own requests produced

  const canvas = $('view'), ctx = canvas.getContext('2d');
  const overlay = $('overlay');
  const handles = [];

  // ---- errors ----------------------------------------------------------------------------
  const errorLine = $('error-line');
  function showError(msg) { errorLine.textContent = msg; errorLine.hidden = !msg; }

  // fetch a JSON API; a non-2xx answer throws with the server's one-line `error`.
  async function api(method, path, body) {
    const opts = { method, headers: {} };
    if (body !== undefined) { opts.body = JSON.stringify(body); opts.headers['content-type'] = 'application/json'; }
    const r = await fetch(path, opts);
    let json = null;
    try { json = await r.json(); } catch (_) { /* empty or not JSON */ }
    if (!r.ok) throw new Error((json && json.error) || `${method} ${path}: HTTP ${r.status}`);
    return json;
  }
  const noteGeneration = (ans) => {
    if (!ans || typeof ans.generation !== 'number') return;
    myGeneration = Math.max(myGeneration, ans.generation);
    // A frame is of the current view only when its generation is this one.
    if (V.state) V.state.generation = Math.max(V.state.generation || 0, ans.generation);
  };

  // ---- camera math (docs: fov_y vertical, aspect from resolution, image y down) ----------
  function basis(cam) {
    const dir = normalize(sub(cam.target, cam.eye));
    const right = normalize(cross(dir, cam.up));
    const up = cross(right, dir);
    const th = Math.tan((cam.fov_y * Math.PI) / 360);
    const aspect = cam.resolution[0] / cam.resolution[1];
    return { dir, right, up, th, aspect };
  }
  // World point -> canvas CSS pixels, or null when behind the camera.
  function project(p) {
    const b = basis(camera), d = sub(p, camera.eye), z = dot(d, b.dir);
    if (z <= 1e-6) return null;
    const nx = dot(d, b.right) / (z * b.th * b.aspect), ny = dot(d, b.up) / (z * b.th);
    return { x: ((nx + 1) / 2) * canvas.clientWidth, y: ((1 - ny) / 2) * canvas.clientHeight };
  }
  // Canvas CSS pixel -> the point on the plane through `p0` facing the camera.
  function unprojectToPlane(x, y, p0) {
    const b = basis(camera);
    const nx = (x / canvas.clientWidth) * 2 - 1, ny = 1 - (y / canvas.clientHeight) * 2;
    const ray = add(b.dir, add(scale(b.right, nx * b.th * b.aspect), scale(b.up, ny * b.th)));
    const t = dot(sub(p0, camera.eye), b.dir) / dot(ray, b.dir);
    return add(camera.eye, scale(ray, t));
  }

  // ---- sending the view: one request in flight, the newest pending state after it --------
  let viewInFlight = false, viewPending = null;
  function sendView(patch) {
    // Merge per top-level key: a pending camera move and a pending light move both survive.
    viewPending = Object.assign(viewPending || {}, clone(patch));
    if (!viewInFlight) flushView();
  }
  async function flushView() {
    while (viewPending) {
      const body = viewPending;
      viewPending = null;
      viewInFlight = true;
      try { noteGeneration(await api('POST', '/api/view', body)); showError(''); }
      catch (e) { showError(e.message); }
      viewInFlight = false;
    }
  }
  const sendCamera = () => sendView({ camera: { eye: tidy(camera.eye), target: tidy(camera.target) } });
  const sendLights = () => sendView({ lights: lights.map((l) => tidyLight(l)) });
  function tidyLight(l) {
    const out = {};
    for (const [k, v] of Object.entries(l)) out[k] = Array.isArray(v) ? tidy(v) : typeof v === 'number' ? tidy([v])[0] : v;
    return out;
  }

  // ---- settings --------------------------------------------------------------------------
  // Returns true when the server took the change; a 400's error goes to the error line and
  // the controls keep what the user typed.
  async function sendSettings(patch) {
    try {
      settings = await api('POST', '/api/settings', patch);
      if (V.state) V.state.settings = settings;
      showError('');
      syncSettingsControls();
      return true;
    } catch (e) { showError(e.message); return false; }
  }

  // ---- frames: the long-poll loop --------------------------------------------------------
  // One answer: u32 LE length L, L bytes of JSON, then each layer's RGBA8 at `offset` bytes
  // after the JSON.
  function parseFrames(buf) {
    const dv = new DataView(buf);
    const L = dv.getUint32(0, true);
    const msg = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, L)));
    const base = 4 + L;
    const layers = (msg.layers || []).map((meta) => {
      const n = meta.width * meta.height * 4;
      const px = new Uint8ClampedArray(buf, base + meta.offset, n);
      return { meta, imageData: new ImageData(px, meta.width, meta.height) };
    });
    return { msg, layers };
  }
  async function pollLoop() {
    let after = 0;
    for (;;) {
      try {
        const r = await fetch(`/api/poll?after=${after}&timeout_ms=10000`, { cache: 'no-store' });
        if (r.status === 204) continue;
        if (!r.ok) throw new Error(`poll: HTTP ${r.status}`);
        const { msg, layers } = parseFrames(await r.arrayBuffer());
        if (typeof msg.seq === 'number') after = msg.seq;
        onFrames(msg, layers);
      } catch (e) {
        // Server gone or restarting: try again in a second, from scratch (a restarted server
        // counts seq and generations from 1 again).
        after = 0; myGeneration = 0; if (V.state) V.state.generation = 0;
        await sleep(1000);
      }
    }
  }
  function onFrames(msg, layers) {
    if (V.state) {
      if (msg.status) V.state.status = msg.status;
      if (typeof msg.generation === 'number') V.state.generation = Math.max(V.state.generation || 0, msg.generation);
    }
    for (const { meta, imageData } of layers) {
      // Keep the layer at its own resolution in an offscreen canvas, scaled when drawn.
      let im = images[meta.name];
      if (!im || im.canvas.width !== meta.width || im.canvas.height !== meta.height) {
        const c = document.createElement('canvas');
        c.width = meta.width; c.height = meta.height;
        im = images[meta.name] = { canvas: c };
      }
      im.canvas.getContext('2d').putImageData(imageData, 0, 0);
      im.meta = meta; im.imageData = imageData;
      V.layers[meta.name] = { seq: msg.seq, ...meta }; // the layer's own seq when it has one
    }
    draw();
    if (layers.some((l) => l.meta.name === 'main')) {
      const m = images.main.meta;
      V.frameCount++;
      V.lastMainFrame = { seq: msg.seq, kind: m.kind, method: m.method, generation: m.generation, frame: m.frame,
                          frames: m.frames, width: m.width, height: m.height, auto: m.auto || null,
                          drawnAt: performance.now() };
    }
    updateStatus(msg.status);
    // A view change that did not come from this page (a script, another tab): reload the view,
    // unless this page is mid-interaction (its own newer state is on its way).
    if (msg.generation > myGeneration && !viewInFlight && !viewPending && !dragging) refreshStateSoon();
  }
  let refreshTimer = null;
  function refreshStateSoon() {
    clearTimeout(refreshTimer);
    refreshTimer = setTimeout(async () => {
      try {
        const st = await api('GET', '/api/state');
        myGeneration = Math.max(myGeneration, st.generation);
        if (viewInFlight || viewPending || dragging) return;
        // Most often only the settings moved the generation: then keep the panel as it is.
        if (near(st.camera, camera) && near(st.lights, lights)) {
          V.state = st; settings = st.settings; syncSettingsControls();
        } else applyState(st);
      } catch (_) { /* the poll loop notices a dead server */ }
    }, 100);
  }

  // ---- drawing ---------------------------------------------------------------------------
  // Fit the canvas to its box at the camera's aspect ratio; its backing store is the CSS
  // size times devicePixelRatio so the scaled frame stays sharp.
  function layout() {
    if (!camera) return;
    const box = $('view-box');
    const bw = box.clientWidth - 16, bh = box.clientHeight - 16;
    const aspect = camera.resolution[0] / camera.resolution[1];
    let w = bw, h = bw / aspect;
    if (h > bh) { h = bh; w = bh * aspect; }
    w = Math.max(1, Math.floor(w)); h = Math.max(1, Math.floor(h));
    canvas.style.width = `${w}px`; canvas.style.height = `${h}px`;
    const dpr = window.devicePixelRatio || 1;
    canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
    // Overlays share the canvas' box.
    const left = canvas.offsetLeft, top = canvas.offsetTop;
    Object.assign(overlay.style, { left: `${left}px`, top: `${top}px`, width: `${w}px`, height: `${h}px`, right: 'auto', bottom: 'auto' });
    const sl = $('split-line');
    sl.style.top = `${top}px`; sl.style.height = `${h}px`;
    // labels along the bottom edge, out of the way of a light handle pinned to the top
    Object.assign($('split-labels').style, { left: `${left}px`, top: `${top}px`, width: `${w}px`, height: `${h}px` });
    draw();
  }

  // The layer shown right of the split / in the diff view must be of the same view as main;
  // until it is, main alone is shown (a stale comparison would mislead).
  const current = (name) => images[name] && images.main && images[name].meta.generation === images.main.meta.generation ? images[name] : null;

  function draw() {
    const W = canvas.width, H = canvas.height;
    ctx.imageSmoothingEnabled = true;
    ctx.imageSmoothingQuality = 'high';
    const main = images.main;
    if (!main) { ctx.fillStyle = '#000'; ctx.fillRect(0, 0, W, H); }
    const diff = viewMode === 'diff' && current('diff');
    const cmp = viewMode === 'split' && current('compare');
    if (diff) ctx.drawImage(diff.canvas, 0, 0, W, H);
    else if (main) ctx.drawImage(main.canvas, 0, 0, W, H);
    if (cmp) {
      // compare right of the line, at the same scale as main
      const x = Math.round(splitX * W);
      const sx = (x / W) * cmp.canvas.width;
      ctx.drawImage(cmp.canvas, sx, 0, cmp.canvas.width - sx, cmp.canvas.height, x, 0, W - x, H);
    }
    const showSplit = viewMode === 'split' && !!settings && !!settings.compare;
    $('split-line').hidden = !showSplit;
    $('split-labels').hidden = !showSplit;
    if (showSplit) {
      $('split-line').style.left = `${canvas.offsetLeft + splitX * canvas.clientWidth}px`;
      $('split-left').textContent = main ? main.meta.method : '';
      $('split-right').textContent = cmp ? cmp.meta.method : `${settings.compare} (pending)`;
    }
    placeHandles();
  }

  // ---- status line -----------------------------------------------------------------------
  function updateStatus(status) {
    const main = images.main && images.main.meta;
    const diff = viewMode === 'diff' && current('diff') ? images.diff.meta : null;
    if (diff) {
      // the server names the pair ("afsm vs reference"); older answers name the second method only
      const pair = /\svs\s/.test(diff.method) ? diff.method : `${main.method} vs ${diff.method}`;
      $('shown-method').textContent = `|ΔV| ${pair} ${diff.width}×${diff.height}`;
    } else if (main) $('shown-method').textContent = `${main.method} (${main.kind}) ${main.width}×${main.height}`;
    if (main) {
      // time and samples are the main layer's: what the frame being refined costs
      $('frame-info').textContent = `${main.ms != null ? main.ms.toFixed(1) : '?'} ms/frame` +
        (main.light_samples ? ` · ${main.light_samples} light samples` : '');
    }
    // The auto preview's choice, from frame times and errors measured on this device
    // (preview_choice.h): shown while the preview it chose is on the canvas.
    const auto = main && main.kind === 'preview' && main.auto ? main.auto : null;
    $('auto-choice').hidden = !auto;
    if (auto) {
      const ms = auto.ms != null ? `${auto.ms.toFixed(1)} ms measured` : 'not measured yet';
      const err = auto.error != null ? `, |ΔV| ${auto.error.toFixed(4)} vs final` : '';
      $('auto-choice').textContent = `auto → ${auto.method} (${auto.move} move: ${ms}${err})`;
      $('auto-choice').title = auto.reason || '';
    }
    if (status) {
      $('phase').textContent = status.phase + (status.error ? ` — ${status.error}` : '');
      const refining = status.phase === 'refining' && status.frames > 0;
      $('progress').hidden = !refining;
      if (refining) { $('progress').max = status.frames; $('progress').value = status.frame; $('phase').textContent = `refining ${status.frame}/${status.frames}`; }
    }
    const dvLayer = current('compare') || current('diff');
    const dv = dvLayer && dvLayer.meta.mean_dv;
    $('mean-dv').textContent = dv != null ? `mean |ΔV| ${dv.toFixed(4)}` : '';
    const d = current('diff');
    const legend = viewMode === 'diff' && d && d.meta.heatmap ? d.meta.heatmap.legend || `${d.meta.heatmap.lo} … ${d.meta.heatmap.hi}` : '';
    $('legend').textContent = legend; $('legend').hidden = !legend;
  }

  // ---- view modes ------------------------------------------------------------------------
  function setMode(mode) {
    viewMode = mode;
    $('split-toggle').checked = mode === 'split';
    $('diff-toggle').checked = mode === 'diff';
    draw(); updateStatus(V.state && V.state.status);
  }
  async function ensureCompare() {
    if (settings && settings.compare) return true;
    const ok = await sendSettings({ compare: 'reference' });
    return ok;
  }
  async function toggleDiff() {
    if (viewMode === 'diff') return setMode(settings && settings.compare ? 'split' : 'main');
    if (await ensureCompare()) setMode('diff');
  }
  async function toggleSplit() {
    if (viewMode === 'split') return setMode('main');
    if (await ensureCompare()) setMode('split');
  }

  // ---- navigation: orbit, pan, zoom, touch -------------------------------------------------
  let dragging = null; // {mode, x, y} while a camera or light drag is on
  const pointers = new Map(); // touch pointers: id -> {x, y}
  function orbit(dx, dy) {
    const up = normalize(camera.up);
    let off = sub(camera.eye, camera.target);
    off = rotate(off, up, -dx * 0.008);            // around the world up: no roll
    // Pitch around the camera's right after the yaw, stopping short of the poles where
    // right = dir × up degenerates.
    const right = normalize(cross(scale(off, -1), up));
    const cur = Math.acos(Math.max(-1, Math.min(1, dot(normalize(off), up))));
    const next = Math.max(0.02, Math.min(Math.PI - 0.02, cur - dy * 0.008));
    off = rotate(off, right, next - cur);
    camera.eye = add(camera.target, off);
  }
  function pan(dx, dy) {
    const b = basis(camera);
    // world units per CSS pixel at the target's distance
    const k = (len(sub(camera.target, camera.eye)) * 2 * b.th) / canvas.clientHeight;
    const d = add(scale(b.right, -dx * k), scale(b.up, dy * k));
    camera.eye = add(camera.eye, d); camera.target = add(camera.target, d);
  }
  function zoom(factor) {
    const off = sub(camera.eye, camera.target);
    const dist = Math.max(diag * 1e-3, Math.min(diag * 20, len(off) * factor));
    camera.eye = add(camera.target, scale(normalize(off), dist));
  }
  const cameraChanged = () => { placeHandles(); sendCamera(); };

  canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  canvas.addEventListener('pointerdown', (e) => {
    if (!camera) return;
    canvas.focus();
    canvas.setPointerCapture(e.pointerId);
    if (e.pointerType === 'touch') { pointers.set(e.pointerId, { x: e.clientX, y: e.clientY }); return; }
    const mode = e.button === 2 || e.button === 1 || (e.button === 0 && e.shiftKey) ? 'pan' : e.button === 0 ? 'orbit' : null;
    if (!mode) return;
    dragging = { mode, x: e.clientX, y: e.clientY };
    canvas.classList.add('dragging');
    e.preventDefault();
  });
  canvas.addEventListener('pointermove', (e) => {
    if (e.pointerType === 'touch') return touchMove(e);
    if (!dragging || dragging.mode === 'light') return;
    const dx = e.clientX - dragging.x, dy = e.clientY - dragging.y;
    dragging.x = e.clientX; dragging.y = e.clientY;
    if (dragging.mode === 'orbit') orbit(dx, dy); else pan(dx, dy);
    cameraChanged();
  });
  const endDrag = (e) => {
    if (e.pointerType === 'touch') { pointers.delete(e.pointerId); touchPrev = null; return; }
    dragging = null; canvas.classList.remove('dragging');
  };
  canvas.addEventListener('pointerup', endDrag);
  canvas.addEventListener('pointercancel', endDrag);
  canvas.addEventListener('wheel', (e) => {
    if (!camera) return;
    e.preventDefault();
    const dy = e.deltaMode === 1 ? e.deltaY * 16 : e.deltaMode === 2 ? e.deltaY * 400 : e.deltaY;
    zoom(Math.exp(dy * 0.0015));
    cameraChanged();
  }, { passive: false });

  // Touch: one finger orbits; two fingers pinch-zoom (distance ratio) and pan (midpoint).
  let touchPrev = null;
  function touchMove(e) {
    if (!pointers.has(e.pointerId)) return;
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    const pts = [...pointers.values()];
    const cur = pts.length >= 2
      ? { n: 2, x: (pts[0].x + pts[1].x) / 2, y: (pts[0].y + pts[1].y) / 2, d: Math.hypot(pts[0].x - pts[1].x, pts[0].y - pts[1].y) }
      : { n: 1, x: pts[0].x, y: pts[0].y };
    if (touchPrev && touchPrev.n === cur.n) {
      if (cur.n === 1) orbit(cur.x - touchPrev.x, cur.y - touchPrev.y);
      else { pan(cur.x - touchPrev.x, cur.y - touchPrev.y); if (cur.d > 0 && touchPrev.d > 0) zoom(touchPrev.d / cur.d); }
      cameraChanged();
    }
    touchPrev = cur;
  }

  // ---- light handles -----------------------------------------------------------------------
  function buildHandles() {
    overlay.textContent = '';
    handles.length = 0;
    lights.forEach((_, i) => {
      const el = document.createElement('div');
      el.className = 'light-handle';
      el.title = `light ${i}: drag to move it in the plane facing the camera`;
      el.addEventListener('pointerdown', (e) => startLightDrag(e, i));
      overlay.appendChild(el);
      handles.push(el);
    });
    placeHandles();
  }
  // A light outside the frame (the shipped scenes' lights often are) keeps its handle pinned
  // to the canvas' border, so it can still be grabbed; dragging keeps the grab offset from
  // the true projection, so the light moves with the pointer either way.
  function placeHandles() {
    if (!camera) return;
    const W = canvas.clientWidth, H = canvas.clientHeight, m = 12;
    handles.forEach((el, i) => {
      const p = lights[i] && project(lights[i].center);
      el.classList.toggle('behind', !p);
      el.classList.toggle('selected', i === selected);
      if (!p) return;
      const x = Math.max(m, Math.min(W - m, p.x)), y = Math.max(m, Math.min(H - m, p.y));
      el.classList.toggle('outside', x !== p.x || y !== p.y);
      el.style.left = `${x}px`; el.style.top = `${y}px`;
    });
  }
  function startLightDrag(e, i) {
    e.preventDefault(); e.stopPropagation();
    selectLight(i);
    const el = handles[i];
    el.setPointerCapture(e.pointerId);
    const r = canvas.getBoundingClientRect();
    const p = project(lights[i].center);
    // Keep the grab offset so the light does not jump to the pointer.
    dragging = { mode: 'light', i, ox: e.clientX - r.left - p.x, oy: e.clientY - r.top - p.y };
    const move = (ev) => {
      const rr = canvas.getBoundingClientRect();
      const c = unprojectToPlane(ev.clientX - rr.left - dragging.ox, ev.clientY - rr.top - dragging.oy, lights[i].center);
      lights[i].center = c;
      V.lastLightMoveAt = performance.now();
      placeHandles();
      sendLights();
      syncLightControls();
    };
    const up = () => {
      el.removeEventListener('pointermove', move);
      el.removeEventListener('pointerup', up);
      el.removeEventListener('pointercancel', up);
      dragging = null;
    };
    el.addEventListener('pointermove', move);
    el.addEventListener('pointerup', up);
    el.addEventListener('pointercancel', up);
  }

  // ---- split line --------------------------------------------------------------------------
  (() => {
    const line = $('split-line');
    line.addEventListener('pointerdown', (e) => {
      e.preventDefault(); e.stopPropagation();
      line.setPointerCapture(e.pointerId);
      const move = (ev) => {
        const r = canvas.getBoundingClientRect();
        splitX = Math.max(0, Math.min(1, (ev.clientX - r.left) / r.width));
        draw();
      };
      const up = () => { line.removeEventListener('pointermove', move); line.removeEventListener('pointerup', up); };
      line.addEventListener('pointermove', move);
      line.addEventListener('pointerup', up);
    });
  })();

  // ---- the light panel ---------------------------------------------------------------------
  const vecInputs = {};
  for (const key of ['center', 'normal']) {
    vecInputs[key] = [0, 1, 2].map((c) => {
      const inp = document.createElement('input');
      inp.type = 'number'; inp.step = 'any'; inp.title = `${key} ${'xyz'[c]}`;
      inp.addEventListener('change', () => {
        const v = Number(inp.value);
        if (!Number.isFinite(v)) { inp.classList.add('bad'); return; }
        inp.classList.remove('bad');
        const l = lights[selected];
        const vec = l[key].slice(); vec[c] = v;
        if (key === 'normal') { if (len(vec) === 0) { inp.classList.add('bad'); return; } setNormal(l, vec); }
        else l.center = vec;
        placeHandles(); sendLights();
      });
      $(`light-${key}`).appendChild(inp);
      return inp;
    });
  }
  // A normal change keeps `u` valid (the server refuses u parallel to the normal): project it
  // into the light's plane, or drop to another axis when it degenerates.
  function setNormal(l, n) {
    l.normal = normalize(n);
    if (!l.u) return;
    let u = sub(l.u, scale(l.normal, dot(l.u, l.normal)));
    if (len(u) < 1e-3) u = sub([0, 0, 1], scale(l.normal, l.normal[2]));
    if (len(u) < 1e-3) u = sub([1, 0, 0], scale(l.normal, l.normal[0]));
    l.u = normalize(u);
  }
  $('point-at-target').addEventListener('click', () => {
    const l = lights[selected];
    if (!l || l.type === 'sphere') return;
    const n = sub(camera.target, l.center);
    if (len(n) === 0) return;
    setNormal(l, n); syncLightControls(); sendLights();
  });
  $('light-pick').addEventListener('change', (e) => selectLight(Number(e.target.value)));
  function selectLight(i) { selected = i; $('light-pick').value = String(i); syncLightControls(); placeHandles(); }

  // A characteristic radius, to carry the light's size across a shape change.
  function lightRadius(l) {
    if (l.type === 'rect') return (l.size[0] + l.size[1]) / 4;
    if (l.type === 'ellipsoid') return (l.radii[0] + l.radii[1]) / 2;
    return l.radius;
  }
  // A valid light of `type` at l's place: only the keys the scene format allows for it.
  function reshapeLight(l, type) {
    const r = lightRadius(l);
    let normal = l.normal || normalize(sub(camera.target, l.center));
    if (len(normal) === 0) normal = [0, -1, 0];
    const out = { type, center: l.center.slice() };
    if (type !== 'sphere') out.normal = normal.slice();
    if (type === 'rect') out.size = [2 * r, 2 * r];
    else if (type === 'ellipsoid') out.radii = [r, r, r * 0.5];
    else out.radius = r;
    out.radiance = l.radiance ? l.radiance.slice() : [1, 1, 1];
    if ((type === 'rect' || type === 'ellipsoid') && l.u) { out.u = l.u.slice(); setNormal(out, out.normal); }
    return out;
  }
  $('light-shape').addEventListener('change', (e) => {
    lights[selected] = reshapeLight(lights[selected], e.target.value);
    syncLightControls(); placeHandles(); sendLights();
  });

  // Size sliders: their ranges follow the scene's size (the bounds' diagonal).
  function sizeSliders(l) {
    const box = $('light-sizes');
    box.textContent = '';
    const entries = l.type === 'rect' ? [['width', 'size', 0], ['height', 'size', 1]]
      : l.type === 'ellipsoid' ? [['radius a', 'radii', 0], ['radius b', 'radii', 1], ['radius c', 'radii', 2]]
        : [['radius', 'radius', -1]];
    for (const [label, key, idx] of entries) {
      const lab = document.createElement('label');
      lab.className = 'field slider';
      const inp = document.createElement('input'), out = document.createElement('output');
      const full = key === 'size' ? diag * 0.5 : diag * 0.25;
      inp.type = 'range'; inp.min = String(full / 500); inp.max = String(full); inp.step = String(full / 1000);
      const get = () => (idx < 0 ? l[key] : l[key][idx]);
      inp.value = String(get()); out.textContent = get().toFixed(3);
      inp.addEventListener('input', () => {
        const v = Number(inp.value);
        const L = lights[selected];
        if (idx < 0) L[key] = v; else L[key][idx] = v;
        out.textContent = v.toFixed(3);
        sendLights();
      });
      lab.append(label, inp, out);
      box.appendChild(lab);
    }
  }
  // Intensity: a log slider around the scene file's intensity, keeping the colour.
  function baseIntensity() {
    const init = V.state && V.state.initial && V.state.initial.lights[selected];
    const m = init && init.radiance ? Math.max(...init.radiance) : 1;
    return m > 0 ? m : 1;
  }
  $('light-intensity').addEventListener('input', (e) => {
    const l = lights[selected];
    const rad = l.radiance || [1, 1, 1];
    const cur = Math.max(...rad);
    const target = baseIntensity() * 10 ** Number(e.target.value);
    l.radiance = cur > 0 ? rad.map((c) => (c * target) / cur) : [target, target, target];
    $('light-intensity-out').textContent = target.toPrecision(3);
    sendLights();
  });
  function syncLightControls() {
    const l = lights[selected];
    $('light-section').hidden = !l;
    if (!l) return;
    const typing = (el) => document.activeElement === el;
    $('light-shape').value = l.type;
    vecInputs.center.forEach((inp, c) => { if (!typing(inp)) inp.value = tidy([l.center[c]])[0]; });
    const hasNormal = l.type !== 'sphere';
    $('light-normal').hidden = !hasNormal; $('point-at-target').hidden = !hasNormal;
    if (hasNormal) vecInputs.normal.forEach((inp, c) => { if (!typing(inp)) inp.value = tidy([l.normal[c]])[0]; });
    if (!dragging || dragging.mode !== 'light') sizeSliders(l);
    const inten = Math.max(...(l.radiance || [1, 1, 1]));
    if (!typing($('light-intensity'))) $('light-intensity').value = String(Math.log10(Math.max(inten, 1e-9) / baseIntensity()));
    $('light-intensity-out').textContent = inten.toPrecision(3);
  }

  // ---- the methods panel -------------------------------------------------------------------
  function fillSelect(sel, options) {
    sel.textContent = '';
    for (const [value, label] of options) {
      const o = document.createElement('option');
      o.value = value; o.textContent = label;
      sel.appendChild(o);
    }
  }
  function buildMethodControls() {
    // Only the methods that run on this session's device (a GPU session offers the GPU's).
    const names = V.methods.filter((m) => m.available !== false).map((m) => m.name);
    fillSelect($('preview-method'), [['auto', 'auto'], ...names.map((n) => [n, n])]);
    fillSelect($('final-method'), names.map((n, i) => [n, i < 10 ? `${n}  (${(i + 1) % 10})` : n]));
    fillSelect($('compare-method'), [['', 'none'], ...names.map((n) => [n, n])]);
    for (const m of V.methods) {
      for (const sel of ['preview-method', 'final-method', 'compare-method']) {
        const o = [...$(sel).options].find((x) => x.value === m.name);
        if (o) o.title = m.description;
      }
    }
    $('preview-method').addEventListener('change', (e) => sendSettings({ preview: e.target.value }));
    $('final-method').addEventListener('change', (e) => setFinal(e.target.value));
    $('compare-method').addEventListener('change', async (e) => {
      if (await sendSettings({ compare: e.target.value })) setMode(e.target.value ? (viewMode === 'diff' ? 'diff' : 'split') : 'main');
    });
    for (const key of ['spp', 'frames']) {
      $(key).addEventListener('change', async (e) => {
        const v = Number(e.target.value);
        const ok = await sendSettings({ [key]: Number.isFinite(v) && e.target.value !== '' ? v : e.target.value });
        e.target.classList.toggle('bad', !ok);
      });
    }
  }
  async function setFinal(name) { if (await sendSettings({ final: name })) buildParams(); }

  const isInfinite = (x) => typeof x !== 'number' || Math.abs(x) >= 1e300;
  // The final method's parameter table as form controls.
  let paramsFor = null;
  function buildParams() {
    const name = settings.final;
    paramsFor = name;
    const m = V.methods.find((x) => x.name === name);
    $('params-title').textContent = `${name} parameters`;
    const box = $('params');
    box.textContent = '';
    if (!m || !m.params.length) { box.textContent = 'none'; box.className = 'help'; return; }
    box.className = '';
    const set = (settings.params && settings.params[name]) || {};
    const scn = sceneMethods[name] || {};
    for (const p of m.params) {
      const value = p.name in set ? set[p.name] : p.name in scn ? scn[p.name] : p.default;
      const row = document.createElement('div');
      row.className = 'param';
      row.title = p.doc || '';
      const lab = document.createElement('label');
      lab.className = 'field';
      let inp;
      const type = String(p.type).toLowerCase();
      if (type === 'bool') {
        inp = document.createElement('input'); inp.type = 'checkbox'; inp.checked = !!value;
      } else if (type === 'string' && p.choices && p.choices.length) {
        inp = document.createElement('select');
        fillSelect(inp, p.choices.map((c) => [c, c]));
        inp.value = value;
      } else if (type === 'int' || type === 'float') {
        inp = document.createElement('input'); inp.type = 'number';
        inp.step = type === 'int' ? '1' : 'any';
        if (!isInfinite(p.min)) inp.min = String(p.min);
        if (!isInfinite(p.max)) inp.max = String(p.max);
        inp.value = String(value);
      } else {
        inp = document.createElement('input'); inp.type = 'text'; inp.value = value == null ? '' : String(value);
      }
      inp.dataset.param = p.name;
      inp.addEventListener('change', async () => {
        let v;
        if (type === 'bool') v = inp.checked;
        else if (type === 'int' || type === 'float') v = inp.value.trim() !== '' && Number.isFinite(Number(inp.value)) ? Number(inp.value) : inp.value;
        else v = inp.value;
        // The server answers a refused value with the method's own error; the text stays.
        const ok = await sendSettings({ params: { [name]: { [p.name]: v } } });
        inp.classList.toggle('bad', !ok);
      });
      lab.append(p.name, inp);
      const doc = document.createElement('div');
      doc.className = 'doc'; doc.textContent = p.doc || '';
      row.append(lab, doc);
      box.appendChild(row);
    }
  }
  function syncSettingsControls() {
    if (!settings) return;
    const focused = document.activeElement;
    if (focused !== $('preview-method')) $('preview-method').value = settings.preview;
    if (focused !== $('final-method')) $('final-method').value = settings.final;
    if (focused !== $('compare-method')) $('compare-method').value = settings.compare || '';
    if (focused !== $('spp')) { $('spp').value = settings.spp; $('spp').classList.remove('bad'); }
    if (focused !== $('frames')) { $('frames').value = settings.frames; $('frames').classList.remove('bad'); }
    if (paramsFor !== settings.final) buildParams();
    if (!settings.compare && viewMode !== 'main') setMode('main');
    updateSaveLinks();
  }
  // The download links follow the settings: the final method at the current spp and frames,
  // with every parameter set for it.
  function updateSaveLinks() {
    const q = new URLSearchParams({ method: settings.final, spp: settings.spp, frames: settings.frames });
    const ps = (settings.params && settings.params[settings.final]) || {};
    for (const [k, v] of Object.entries(ps)) q.append('param', `${k}=${v}`);
    for (const fmt of ['png', 'exr']) {
      const a = $(`save-${fmt}`);
      const qq = new URLSearchParams(q); qq.set('format', fmt);
      a.href = `/api/frame?${qq}`;
      a.download = `${settings.final}.${fmt}`;
    }
  }

  // ---- buttons and keys ----------------------------------------------------------------------
  async function resetView() {
    try {
      noteGeneration(await api('POST', '/api/reset'));
      showError('');
      applyState(await api('GET', '/api/state'));
    } catch (e) { showError(e.message); }
  }
  async function refineNow() {
    try { noteGeneration(await api('POST', '/api/refine')); showError(''); } catch (e) { showError(e.message); }
  }
  $('reset-view').addEventListener('click', resetView);
  $('refine-now').addEventListener('click', refineNow);
  $('split-toggle').addEventListener('change', async (e) => {
    if (e.target.checked) await toggleSplit(); else setMode('main');
    $('split-toggle').checked = viewMode === 'split';
  });
  $('diff-toggle').addEventListener('change', () => toggleDiff().then(() => { $('diff-toggle').checked = viewMode === 'diff'; }));

  document.addEventListener('keydown', (e) => {
    const t = e.target;
    // Keys type into fields, not into the viewer.
    if (t && (t.tagName === 'INPUT' || t.tagName === 'TEXTAREA' || t.tagName === 'SELECT' || t.isContentEditable)) return;
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    if (/^[0-9]$/.test(e.key)) {
      const idx = e.key === '0' ? 9 : Number(e.key) - 1;
      const m = V.methods.filter((x) => x.available !== false)[idx];  // as the final select lists them
      if (m) { $('final-method').value = m.name; setFinal(m.name); }
    } else if (e.key === 'r') refineNow();
    else if (e.key === 'd') toggleDiff();
    else if (e.key === 's') toggleSplit();
    else if (e.key === 'Home') resetView();
    else return;
    e.preventDefault();
  });

  // ---- start -------------------------------------------------------------------------------
  // st.camera and st.lights come resolved (docs/viewer.md, GET /api/state): every key a scene
  // file may leave out is filled in with its default (camera up, fov_y, resolution; a light's
  // radiance and u), so the page reads those without fallbacks; only radiance_texture may be
  // absent, and the page never reads it.
  function applyState(st) {
    V.state = st;
    camera = clone(st.camera);
    lights = clone(st.lights);
    settings = st.settings;
    const b = st.bounds;
    if (b && b.min && b.max) diag = len(sub(b.max, b.min)) || 1;
    if (selected >= lights.length) selected = 0;
    fillSelect($('light-pick'), lights.map((l, i) => [String(i), `${i}: ${l.type}`]));
    $('light-pick-row').hidden = lights.length < 2;
    buildHandles();
    syncLightControls();
    syncSettingsControls();
    layout();
  }
  async function start() {
    for (;;) {
      try {
        const [methods, st] = await Promise.all([api('GET', '/api/methods'), api('GET', '/api/state')]);
        V.methods = methods;
        try { const doc = await api('GET', '/api/scene'); sceneMethods = doc.methods || {}; } catch (_) { sceneMethods = {}; }
        myGeneration = st.generation;
        // The device every frame renders on (`penumbra view --device`).
        const dev = st.device || { choice: 'cpu', name: 'cpu' };
        $('device').textContent = dev.choice === 'cpu' ? 'CPU' : `GPU: ${dev.name}`;
        V.device = dev;
        buildMethodControls();
        applyState(st);
        break;
      } catch (e) {
        showError(`cannot reach the server: ${e.message}`);
        await sleep(1000);
      }
    }
    showError('');
    new ResizeObserver(layout).observe($('view-box'));
    pollLoop();
  }
  start();
})();
