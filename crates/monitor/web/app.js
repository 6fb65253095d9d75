// colony monitor: the page's script. Plain JavaScript, no library.
//
// The server sends {"t":"world"} snapshots (at most 30 a second), each new
// whole frame's robots and pucks just before its snapshot as one binary
// message (typed arrays: see decodeBodies), {"t":"hub"}
// about once a second, {"t":"monitor"} (what the monitor itself refused or
// dropped) on connecting and each second it changes, and {"t":"reply"}
// answers; the page sends requests (take, release, drive, goto, publish).
// window.colony exposes what the page shows, for people at the console and for
// the browser tests. The socket, the view transform, escaping and the banners
// are common.js's, shared with the game page.
import {
  $, Transform, drawText, esc, fitBacking, pixelRatio, serverLink, showBanners, showChip, showMessage, tenth,
  withToken,
} from './common.js';

$('tasks-link').href = withToken('/tasks');

const KIND_COLOURS = ['#e0452b', '#2b6fe0', '#23a446', '#e0a21b', '#8e44d6', '#e0702b', '#1fb5b5', '#d63384'];
const DEFAULT_SIZES = { robot_length: 12.5, robot_width: 10.8, gripper_radius: 3.6, puck_diameter: 6.3 };
const STALE_MS = 2000;

const canvas = $('arena');
const ctx = canvas.getContext('2d', { alpha: false });
const plot = $('plot');
const pctx = plot.getContext('2d');

let world = null; // the newest snapshot
let shown = null; // the snapshot drawn (held back while the view is paused)
let bodies = null; // the newest frame's robots and pucks (decodeBodies)
let shownBodies = null; // the bodies drawn (held back while the view is paused)
let hub = null;
let paused = false;
let dirty = true;
let plotDirty = true;
const view = { cx: 0, cy: 0, scale: 3, fitted: false, auto: true }; // auto: refit on resize until the user pans or zooms
const selected = new Set();
let pcSeries = [];
let link = null;
let connected = false;
let serverLostSince = Date.now();

const api = {
  robots: 0, pucks: 0, step: null, fps: 0, frames: 0, drawMs: 0,
  drawn: { step: null, robots: 0, pucks: 0 }, // what the canvas shows now
  // Bodies messages taken, redraws of the arena, distinct frames drawn, and whole frames
  // the monitor dropped for a missing part (never drawn) and put together.
  bodyFrames: 0, draws: 0, framesDrawn: 0, framesMissing: 0, framesWhole: 0, raster: false,
  shapes: { robots: 0, pucks: 0 }, // bodies drawn as shapes, in view (none as pixels)
  redrawEveryFrame: false,
  connected: false, hubStale: false, visionStale: false, serverLostSince: null,
  hubStaleSince: null, visionStaleSince: null,
  held: [], all: false, selected: [], states: {}, pc: null,
  channels: {}, minPriority: null, paused: false, worlds: 0, hubs: 0, lastReply: null, monitor: null,
  worldToClient, select, send,
};
// Each robot's [x, y, theta] by id, from the newest bodies (built when asked: 10,000 a frame
// would cost every frame for a reader that is rarely there).
Object.defineProperty(api, 'poses', {
  enumerable: true,
  get() {
    const out = {};
    const b = bodies;
    if (b) for (let i = 0; i < b.n; i++) out[b.ids[i]] = [b.pose[3 * i], b.pose[3 * i + 1], b.pose[3 * i + 2]];
    return out;
  },
});
window.colony = api;

// ---- the connection ---------------------------------------------------
function connect() {
  link = serverLink('/ws', {
    onOpen() {
      connected = true;
      serverLostSince = null;
      updateBanners();
    },
    onMessage(msg) {
      if (msg.t === 'world') onWorld(msg);
      else if (msg.t === 'hub') onHub(msg);
      else if (msg.t === 'monitor') onMonitor(msg);
      else if (msg.t === 'reply') onReply(msg);
    },
    onBinary(buf) {
      const b = decodeBodies(buf);
      if (b) onBodies(b);
    },
    onClose(wasConnected) {
      if (wasConnected || serverLostSince === null) serverLostSince = Date.now();
      connected = false;
      updateBanners();
    },
  });
}

function send(obj) {
  if (link && link.send(obj)) return true;
  message('override-msg', 'not connected to the monitor server', false);
  return false;
}

// ---- incoming ----------------------------------------------------------
// The bodies message (crates/monitor/src/state/bodies.rs): a 24-byte header
// ('CWB1', robots n, pucks m, frame number, step as f64), then typed arrays,
// each at a multiple of 4 bytes: robot poses f32 [x, y, theta] * n, robot ids
// u32 * n, carried puck ids u32 * n (0xffffffff: none), puck positions f32
// [x, y] * m, puck ids u32 * m, puck kinds u8 * m. Sorted by id. Views, not copies.
const BODIES_MAGIC = 0x31425743; // 'CWB1' read as a little-endian u32
const NOT_CARRYING = 0xffffffff;
function decodeBodies(buf) {
  if (buf.byteLength < 24) return null;
  const dv = new DataView(buf);
  if (dv.getUint32(0, true) !== BODIES_MAGIC) return null;
  const n = dv.getUint32(4, true);
  const m = dv.getUint32(8, true);
  if (buf.byteLength !== 24 + 20 * n + 13 * m) return null;
  let o = 24;
  const take = (Type, count, size) => { const a = new Type(buf, o, count); o += count * size; return a; };
  return {
    n, m, frame: dv.getUint32(12, true), step: dv.getFloat64(16, true),
    pose: take(Float32Array, 3 * n, 4), ids: take(Uint32Array, n, 4), carrying: take(Uint32Array, n, 4),
    puckPos: take(Float32Array, 2 * m, 4), puckIds: take(Uint32Array, m, 4), kinds: take(Uint8Array, m, 1),
  };
}

// The index of id in a sorted Uint32Array, or -1.
function indexOf(ids, id) {
  if (id < ids.length && ids[id] === id) return id; // ids 0..n-1, the usual case
  let lo = 0;
  let hi = ids.length - 1;
  while (lo <= hi) {
    const mid = (lo + hi) >> 1;
    if (ids[mid] === id) return mid;
    if (ids[mid] < id) lo = mid + 1; else hi = mid - 1;
  }
  return -1;
}

function onBodies(b) {
  bodies = b;
  api.bodyFrames += 1;
  api.robots = b.n;
  api.pucks = b.m;
  api.step = b.step;
  if (!paused) { shownBodies = b; dirty = true; }
  if (!view.fitted) fit();
  $('step').textContent = String(b.step);
  $('nrobots').textContent = String(b.n);
  $('npucks').textContent = String(b.m);
}

function onWorld(w) {
  world = w;
  api.worlds += 1;
  api.framesMissing = w.frames_missing ?? 0;
  api.framesWhole = w.frames ?? 0;
  api.boxes = (w.boxes ?? []).map((b) => [b[1], b[2]]);
  api.goal = w.goal ?? null;
  api.held = w.held;
  api.all = w.all;
  api.hubStaleSince = w.hub_stale_since;
  api.visionStaleSince = w.vision_stale_since;
  api.worldPhase = w.world_phase ?? 'live';
  const states = {};
  for (const i of w.intents) states[i[0]] = i[1];
  api.states = states;
  if (w.pc) {
    api.pc = w.pc[1];
    const last = pcSeries[pcSeries.length - 1];
    if (!last || w.pc[0] > last[0]) { pcSeries.push(w.pc); plotDirty = true; }
    else if (w.pc[0] < last[0]) { pcSeries = [w.pc]; plotDirty = true; }
  }
  if (!paused) { shown = w; dirty = true; }
  if (!view.fitted) fit();
  if (w.step === null) $('step').textContent = '–';
  $('missing').textContent = String(api.framesMissing);
  $('missing-chip').classList.toggle('bad', api.framesMissing > 0);
  $('missing-chip').title = `${api.framesWhole} whole frames of the world taken, ${api.framesMissing} dropped `
    + 'for a part lost on the way (never drawn)';
  $('pcnow').textContent = w.pc ? `${w.pc[1].toFixed(1)} %` : '–';
  $('held-line').textContent = w.held.length
    ? `Holding ${w.all ? 'all: ' : ''}${listIds(w.held)}${w.min_raised ? ' (hub minimum priority raised)' : ''}`
    : 'Holding: none (the controllers drive every robot)';
  updateBanners();
}

function onHub(h) {
  hub = h;
  api.hubs += 1;
  api.minPriority = h.min_priority;
  if (h.pc && h.pc.length) {
    // The server's history, plus any newer points from world snapshots.
    const last = h.pc[h.pc.length - 1][0];
    pcSeries = h.pc.concat(pcSeries.filter((p) => p[0] > last));
    plotDirty = true;
  }
  renderHub();
}

function onReply(r) {
  api.lastReply = r;
  if (r.to === 'publish') {
    message('forge-msg', r.msg, r.ok);
    if (!r.ok && r.line) markError(r.line, r.column);
  } else if (!(r.ok && r.to === 'drive')) {
    message('override-msg', r.msg, r.ok);
  }
}

function message(id, text, ok) {
  showMessage($(id), text, ok);
}

// Puts the cursor on the line and column a forged packet's error names.
function markError(line, column) {
  const ta = $('forge');
  const lines = ta.value.split('\n');
  let at = 0;
  for (let i = 0; i < line - 1 && i < lines.length; i++) at += lines[i].length + 1;
  at = Math.min(ta.value.length, at + Math.max(0, (column || 1) - 1));
  ta.focus();
  ta.setSelectionRange(at, Math.min(ta.value.length, at + 1));
}

// ---- staleness ----------------------------------------------------------
function clock(ms) {
  return new Date(ms).toLocaleTimeString([], { hour12: false });
}

function updateBanners() {
  const notes = [];
  api.connected = connected;
  api.serverLostSince = connected ? null : serverLostSince;
  const note = (kind, text) => notes.push({ cls: `stale-banner ${kind}`, id: `banner-${kind}`, text });
  if (!connected) {
    note('server', `monitor server lost since ${clock(serverLostSince || Date.now())}: reconnecting…`);
  }
  const w = world;
  const phase = w ? (w.world_phase ?? 'live') : 'none';
  api.hubStale = !connected || !w || w.hub_stale_since !== null;
  api.visionStale = !connected || !w || w.vision_stale_since !== null;
  // No world was ever seen on vision (beside a task board or a game): nothing to draw or to
  // call stale, so the world's panels stay hidden rather than alarming.
  const noWorld = connected && phase === 'none';
  $('live').hidden = noWorld;
  $('plot-box').hidden = noWorld;
  $('override').hidden = noWorld;
  if (connected && w) {
    if (w.hub_stale_since !== null) note('hub', `hub stale since ${clock(w.hub_stale_since)}: no word from the hub; the monitor keeps asking`);
    if (phase === 'stale') note('vision', `vision stale since ${clock(w.vision_stale_since)}: no world state on <vision>`);
    if (phase === 'ended') {
      notes.push({ cls: 'info-banner', id: 'banner-ended', text: `the world ended: nothing on <vision> since ${clock(w.vision_stale_since)} (its last frame is dimmed)` });
    }
    if (noWorld) notes.push({ cls: 'info-banner', id: 'banner-no-world', text: 'no world on <vision>: the hub view is below; the arena appears when a world is published' });
  }
  if (showBanners($('banners'), notes)) dirty = true;
  const alarm = api.hubStale || (api.visionStale && phase === 'stale');
  if (!connected) showChip($('conn'), 'server lost', false);
  else if (alarm) showChip($('conn'), 'stale', false);
  else if (phase === 'ended') showChip($('conn'), 'ended', null);
  else showChip($('conn'), 'live', true);
}
setInterval(updateBanners, 500);

// ---- the view -------------------------------------------------------------
function sizes() {
  return (shown && shown.sizes) || DEFAULT_SIZES;
}

function extent() {
  const w = shown || world;
  if (w && w.arena) return [w.arena.width, w.arena.height];
  let m = 50;
  const b = shownBodies || bodies;
  if (b) for (const v of b.pose) m = Math.max(m, Math.abs(v));
  if (b) for (const v of b.puckPos) m = Math.max(m, Math.abs(v));
  return [2 * m, 2 * m];
}

function fit() {
  const w = shown || world;
  const b = shownBodies || bodies;
  if (!w || (!w.arena && !(b && b.n))) return;
  const [ew, eh] = extent();
  const r = canvas.getBoundingClientRect();
  if (r.width < 10 || r.height < 10) return;
  view.scale = Math.min(r.width / (ew * 1.06), r.height / (eh * 1.06));
  view.cx = 0;
  view.cy = 0;
  view.fitted = true;
  dirty = true;
}

function resize() {
  if (fitBacking(canvas)) dirty = true;
  if (fitBacking(plot)) plotDirty = true;
}
new ResizeObserver(() => { resize(); if (!view.fitted || view.auto) fit(); }).observe(canvas);
new ResizeObserver(resize).observe(plot);

// World (cm, y up) to canvas device pixels: the panned and zoomed view.
function transform() {
  return Transform.centred(canvas, view.cx, view.cy, view.scale);
}

function worldToClient(x, y) {
  return transform().toClient(x, y);
}

function clientToWorld(cx, cy) {
  return transform().fromClient(cx, cy);
}

function roundedRect(c, x, y, w, h, r) {
  r = Math.max(0, Math.min(r, w / 2, h / 2));
  c.moveTo(x + r, y);
  c.lineTo(x + w - r, y);
  c.arc(x + w - r, y + r, r, -Math.PI / 2, 0);
  c.lineTo(x + w, y + h - r);
  c.arc(x + w - r, y + h - r, r, 0, Math.PI / 2);
  c.lineTo(x + r, y + h);
  c.arc(x + r, y + h - r, r, Math.PI / 2, Math.PI);
  c.lineTo(x, y + r);
  c.arc(x + r, y + r, r, Math.PI, 1.5 * Math.PI);
  c.closePath();
}

function draw() {
  const t0 = performance.now();
  const t = transform();
  const { k, ox, oy, dpr } = t;
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = '#d7dbe0';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const w = shown;
  if (!w) {
    label('waiting for the world on <vision>…', canvas.width / 2, canvas.height / 2, '#4a5563', 16 * dpr, 'center');
    return;
  }
  // The bodies drawn: the newest frame's (an empty one before any came).
  const b = shownBodies || EMPTY_BODIES;
  const s = sizes();
  const px = 1 / k; // one device pixel, in cm
  ctx.setTransform(k, 0, 0, -k, ox, oy);
  // Walls and floor.
  const [aw, ah] = extent();
  const corner = w.arena ? w.arena.corner : 0;
  ctx.beginPath();
  roundedRect(ctx, -aw / 2, -ah / 2, aw, ah, corner);
  ctx.fillStyle = '#f6f3ea';
  ctx.fill();
  ctx.lineWidth = Math.max(2 * px, 1.5);
  ctx.strokeStyle = '#3a3f47';
  ctx.stroke();

  // Pucks and robots: when a robot is only a few pixels long, as pixels written straight into
  // an image (a path of 100,000 arcs takes the software canvas far longer than a frame);
  // otherwise as shapes, only those in view.
  const held = new Set(w.held);
  const raster = s.robot_length * k < RASTER_BELOW_PX;
  api.raster = raster;
  const pr = Math.max(s.puck_diameter / 2, 1.2 * px);
  const inView = viewBox(t, Math.max(s.robot_length, s.puck_diameter) * 2);
  // Bodies drawn as shapes (those in view; none when drawn as pixels).
  const asShapes = { robots: 0, pucks: 0 };
  if (raster) {
    rasterBodies(b, k, ox, oy, held);
  } else {
    const byKind = [];
    for (let i = 0; i < b.m; i++) {
      const x = b.puckPos[2 * i];
      const y = b.puckPos[2 * i + 1];
      if (!inView(x, y)) continue;
      asShapes.pucks += 1;
      const kind = b.kinds[i];
      const path = byKind[kind] || (byKind[kind] = new Path2D());
      path.moveTo(x + pr, y);
      path.arc(x, y, pr, 0, 2 * Math.PI);
    }
    byKind.forEach((path, kind) => {
      ctx.fillStyle = KIND_COLOURS[kind % KIND_COLOURS.length];
      ctx.fill(path);
    });
  }

  // A goal (box pushing): a ringed cross.
  if (w.goal) {
    const [gx, gy] = w.goal;
    const gr = 12;
    ctx.lineWidth = 2 * px;
    ctx.strokeStyle = '#23794a';
    ctx.beginPath();
    ctx.arc(gx, gy, gr, 0, 2 * Math.PI);
    ctx.moveTo(gx - gr * 1.5, gy);
    ctx.lineTo(gx + gr * 1.5, gy);
    ctx.moveTo(gx, gy - gr * 1.5);
    ctx.lineTo(gx, gy + gr * 1.5);
    ctx.stroke();
  }
  // Boxes robots push: rectangles along their heading.
  for (const [, bx, by, theta, length, width] of w.boxes ?? []) {
    ctx.save();
    ctx.translate(bx, by);
    ctx.rotate(theta);
    ctx.fillStyle = '#9c6b30';
    ctx.fillRect(-length / 2, -width / 2, length, width);
    ctx.restore();
  }

  // Cache points: squares in their kind's colour.
  const showIntents = $('show-intents').checked;
  if (showIntents && w.caches.length) {
    ctx.lineWidth = 2 * px;
    ctx.setLineDash([4 * px, 3 * px]);
    const half = s.puck_diameter * 1.2;
    for (const c of w.caches) {
      ctx.strokeStyle = KIND_COLOURS[c[1] % KIND_COLOURS.length];
      ctx.strokeRect(c[2] - half, c[3] - half, 2 * half, 2 * half);
    }
    ctx.setLineDash([]);
  }

  // A robot's [x, y] by id, if it is in the frame.
  const at = (id) => {
    const i = indexOf(b.ids, id);
    return i < 0 ? null : [b.pose[3 * i], b.pose[3 * i + 1]];
  };

  // Each controller's target: a dashed line from the robot.
  if (showIntents) {
    ctx.beginPath();
    for (const i of w.intents) {
      const r = at(i[0]);
      if (!r || i[2] === null || held.has(i[0])) continue;
      ctx.moveTo(r[0], r[1]);
      ctx.lineTo(i[2], i[3]);
      ctx.moveTo(i[2] - 2, i[3] - 2); ctx.lineTo(i[2] + 2, i[3] + 2);
      ctx.moveTo(i[2] - 2, i[3] + 2); ctx.lineTo(i[2] + 2, i[3] - 2);
    }
    ctx.strokeStyle = 'rgba(40, 60, 90, 0.55)';
    ctx.lineWidth = 1.5 * px;
    ctx.setLineDash([5 * px, 4 * px]);
    ctx.stroke();
    ctx.setLineDash([]);
  }
  // The operator's targets.
  if (w.targets.length) {
    ctx.beginPath();
    for (const [id, tx, ty] of w.targets) {
      const r = at(id);
      if (r) { ctx.moveTo(r[0], r[1]); ctx.lineTo(tx, ty); }
      ctx.moveTo(tx + 4, ty);
      ctx.arc(tx, ty, 4, 0, 2 * Math.PI);
    }
    ctx.strokeStyle = '#c2185b';
    ctx.lineWidth = 2 * px;
    ctx.stroke();
  }

  // Robots: oriented bodies, C-shaped grippers at the front, heading marks.
  const L = s.robot_length;
  const W = s.robot_width;
  const gr = s.gripper_radius || s.puck_diameter * 0.57;
  const mouth = (130 / 2) * Math.PI / 180; // half the gripper's mouth
  const shapes = { normal: new Path2D(), held: new Path2D() };
  const grippers = new Path2D();
  const heads = new Path2D();
  for (let i = 0; i < b.n && !raster; i++) {
    const x = b.pose[3 * i];
    const y = b.pose[3 * i + 1];
    if (!inView(x, y)) continue;
    asShapes.robots += 1;
    const th = b.pose[3 * i + 2];
    const id = b.ids[i];
    const c = Math.cos(th);
    const sn = Math.sin(th);
    const pt = (fx, fy) => [x + fx * c - fy * sn, y + fx * sn + fy * c];
    const path = held.has(id) ? shapes.held : shapes.normal;
    const c0 = pt(-L / 2, -W / 2);
    const c1 = pt(L / 2, -W / 2);
    const c2 = pt(L / 2, W / 2);
    const c3 = pt(-L / 2, W / 2);
    path.moveTo(c0[0], c0[1]); path.lineTo(c1[0], c1[1]); path.lineTo(c2[0], c2[1]); path.lineTo(c3[0], c3[1]); path.closePath();
    // The C-shaped gripper: straight jaws from the body's front to the
    // pocket's centre, then lips following the pocket round to the mouth.
    const g = pt(L / 2 + gr, 0);
    for (const side of [1, -1]) {
      const j0 = pt(L / 2, side * gr);
      const j1 = pt(L / 2 + gr, side * gr);
      grippers.moveTo(j0[0], j0[1]);
      grippers.lineTo(j1[0], j1[1]);
      grippers.arc(g[0], g[1], gr, th + side * Math.PI / 2, th + side * mouth, side > 0);
    }
    const h1 = pt(L / 2 - 1, 0);
    const h2 = pt(-L / 4, W / 3);
    const h3 = pt(-L / 4, -W / 3);
    heads.moveTo(h1[0], h1[1]); heads.lineTo(h2[0], h2[1]); heads.lineTo(h3[0], h3[1]); heads.closePath();
  }
  ctx.fillStyle = '#3c4651';
  ctx.fill(shapes.normal);
  ctx.fillStyle = '#c2185b';
  ctx.fill(shapes.held);
  ctx.fillStyle = 'rgba(255,255,255,0.85)';
  ctx.fill(heads);
  ctx.strokeStyle = '#1d232b';
  ctx.lineWidth = Math.max(0.8, 1.5 * px); // the jaws are about 8 mm thick
  ctx.lineCap = 'round';
  ctx.stroke(grippers);

  // Carried pucks, ringed so they stand out in the gripper.
  for (let i = 0; i < b.n && !raster; i++) {
    if (b.carrying[i] === NOT_CARRYING || !inView(b.pose[3 * i], b.pose[3 * i + 1])) continue;
    const j = indexOf(b.puckIds, b.carrying[i]);
    if (j < 0) continue;
    ctx.beginPath();
    ctx.arc(b.puckPos[2 * j], b.puckPos[2 * j + 1], pr, 0, 2 * Math.PI);
    ctx.fillStyle = KIND_COLOURS[b.kinds[j] % KIND_COLOURS.length];
    ctx.fill();
    ctx.lineWidth = Math.max(1, 1.5 * px);
    ctx.strokeStyle = '#fff';
    ctx.stroke();
  }

  // Selection rings.
  if (selected.size) {
    ctx.beginPath();
    const ring = Math.max(L * 0.85, 6 * px);
    for (const id of selected) {
      const r = at(id);
      if (!r) continue;
      ctx.moveTo(r[0] + ring, r[1]);
      ctx.arc(r[0], r[1], ring, 0, 2 * Math.PI);
    }
    ctx.strokeStyle = '#f2b705';
    ctx.lineWidth = Math.max(2, 3 * px);
    ctx.stroke();
  }

  // Labels, in screen space: id and FSM state.
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  const showLabels = $('show-labels').checked && (b.n <= 64 || view.scale * dpr > 6);
  if (showLabels) {
    const states = new Map();
    for (const i of w.intents) states.set(i[0], i[1]);
    ctx.font = `${11 * dpr}px system-ui, sans-serif`;
    ctx.textAlign = 'center';
    for (let i = 0; i < b.n; i++) {
      const x = b.pose[3 * i];
      const y = b.pose[3 * i + 1];
      if (!inView(x, y)) continue;
      const id = b.ids[i];
      const sx = ox + x * k;
      const sy = oy - y * k - (L * 0.9) * k - 3 * dpr;
      const st = held.has(id) ? 'OPERATOR' : (showIntents && states.get(id)) || '';
      const text = st ? `${id} ${st}` : String(id);
      ctx.fillStyle = 'rgba(255,255,255,0.8)';
      const tw = ctx.measureText(text).width;
      ctx.fillRect(sx - tw / 2 - 2 * dpr, sy - 10 * dpr, tw + 4 * dpr, 13 * dpr);
      ctx.fillStyle = held.has(id) ? '#c2185b' : '#1d232b';
      ctx.fillText(text, sx, sy);
    }
  }
  scaleBar(t);
  const ended = connected && world && world.world_phase === 'ended' && !api.hubStale;
  if (ended) {
    // A finished run: history, not an alarm.
    ctx.fillStyle = 'rgba(215, 219, 224, 0.6)';
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    label(`ended at ${clock(world.vision_stale_since)}`, canvas.width / 2, 40 * dpr, '#4a5563', 20 * dpr, 'center');
  } else if (api.hubStale || api.visionStale) {
    ctx.fillStyle = 'rgba(110, 110, 110, 0.35)';
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    const since = !connected ? serverLostSince : (world && (world.hub_stale_since || world.vision_stale_since));
    label(`STALE since ${clock(since || Date.now())}`, canvas.width / 2, 40 * dpr, '#7a1f17', 22 * dpr, 'center');
  }
  if (paused) label('view paused', 10 * dpr, 22 * dpr, '#a8322b', 14 * dpr, 'left');
  api.drawn = { step: shownBodies ? b.step : w.step, robots: b.n, pucks: b.m };
  api.draws += 1;
  api.shapes = asShapes;
  if (b !== lastDrawn) { api.framesDrawn += 1; lastDrawn = b; }
  api.drawMs = performance.now() - t0;
}

const EMPTY_BODIES = decodeBodies(new Uint32Array([BODIES_MAGIC, 0, 0, 0, 0, 0]).buffer);
let lastDrawn = null;
// Below this many device pixels to a robot's length, bodies are drawn as pixels.
const RASTER_BELOW_PX = 4;

// Whether a world point is within `margin` cm of the canvas.
function viewBox(t, margin) {
  const x0 = (0 - t.ox) / t.k - margin;
  const x1 = (canvas.width - t.ox) / t.k + margin;
  const y1 = (t.oy - 0) / t.k + margin;
  const y0 = (t.oy - canvas.height) / t.k - margin;
  return (x, y) => x >= x0 && x <= x1 && y >= y0 && y <= y1;
}

// Colours as little-endian RGBA words, for an ImageData's Uint32Array.
function rgba(hex) {
  const v = parseInt(hex.slice(1), 16);
  return (0xff000000 | ((v & 0xff) << 16) | (v & 0xff00) | ((v >> 16) & 0xff)) >>> 0;
}
const KIND_WORDS = KIND_COLOURS.map(rgba);
const ROBOT_WORD = rgba('#3c4651');
const HELD_WORD = rgba('#c2185b');
const rasterLayer = { canvas: document.createElement('canvas'), ctx: null, image: null, words: null };

// Pucks and robots as small squares written into an image the size of the canvas, then drawn
// over the floor in one go: pucks at least 2 pixels across, robots 3, in their colours.
function rasterBodies(b, k, ox, oy, held) {
  const W = canvas.width;
  const H = canvas.height;
  if (!rasterLayer.image || rasterLayer.image.width !== W || rasterLayer.image.height !== H) {
    rasterLayer.canvas.width = W;
    rasterLayer.canvas.height = H;
    rasterLayer.ctx = rasterLayer.canvas.getContext('2d');
    rasterLayer.image = rasterLayer.ctx.createImageData(W, H);
    rasterLayer.words = new Uint32Array(rasterLayer.image.data.buffer);
  }
  const px = rasterLayer.words;
  px.fill(0);
  const square = (cx, cy, side, word) => {
    const x0 = Math.max(0, Math.round(cx - side / 2));
    const y0 = Math.max(0, Math.round(cy - side / 2));
    const x1 = Math.min(W, x0 + side);
    const y1 = Math.min(H, y0 + side);
    for (let y = y0; y < y1; y++) {
      const row = y * W;
      for (let x = x0; x < x1; x++) px[row + x] = word;
    }
  };
  const s = sizes();
  const puckSide = Math.max(2, Math.round(s.puck_diameter * k));
  for (let i = 0; i < b.m; i++) {
    square(ox + b.puckPos[2 * i] * k, oy - b.puckPos[2 * i + 1] * k, puckSide,
      KIND_WORDS[b.kinds[i] % KIND_WORDS.length]);
  }
  const robotSide = Math.max(3, Math.round(s.robot_length * k));
  const anyHeld = held.size > 0;
  for (let i = 0; i < b.n; i++) {
    const word = anyHeld && held.has(b.ids[i]) ? HELD_WORD : ROBOT_WORD;
    square(ox + b.pose[3 * i] * k, oy - b.pose[3 * i + 1] * k, robotSide, word);
  }
  rasterLayer.ctx.putImageData(rasterLayer.image, 0, 0);
  ctx.save();
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.drawImage(rasterLayer.canvas, 0, 0);
  ctx.restore();
}

function label(text, x, y, colour, px, align) {
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  drawText(ctx, text, x, y, { fill: colour, px, align });
}

function scaleBar(t) {
  const { k, dpr } = t;
  const targetPx = 120 * dpr;
  const steps = [1, 2, 5, 10, 20, 25, 50, 100, 200, 500, 1000, 2000, 5000];
  let cm = steps[0];
  for (const s of steps) if (s * k <= targetPx) cm = s;
  const x = 12 * dpr;
  const y = canvas.height - 14 * dpr;
  ctx.strokeStyle = '#1d232b';
  ctx.lineWidth = 2 * dpr;
  ctx.beginPath();
  ctx.moveTo(x, y - 5 * dpr); ctx.lineTo(x, y); ctx.lineTo(x + cm * k, y); ctx.lineTo(x + cm * k, y - 5 * dpr);
  ctx.stroke();
  ctx.font = `${11 * dpr}px system-ui, sans-serif`;
  ctx.textAlign = 'left';
  ctx.fillStyle = '#1d232b';
  ctx.fillText(cm >= 100 ? `${cm / 100} m` : `${cm} cm`, x + cm * k + 6 * dpr, y);
}

function drawPlot() {
  const dpr = pixelRatio();
  const W = plot.width;
  const H = plot.height;
  pctx.setTransform(1, 0, 0, 1, 0, 0);
  pctx.fillStyle = '#fff';
  pctx.fillRect(0, 0, W, H);
  const left = 34 * dpr;
  const right = W - 8 * dpr;
  const top = 8 * dpr;
  const bottom = H - 20 * dpr;
  pctx.font = `${10 * dpr}px system-ui, sans-serif`;
  pctx.strokeStyle = '#e1e4e8';
  pctx.fillStyle = '#6b7684';
  pctx.lineWidth = 1;
  pctx.textAlign = 'right';
  for (const v of [0, 25, 50, 75, 100]) {
    const y = bottom - (v / 100) * (bottom - top);
    pctx.beginPath(); pctx.moveTo(left, y); pctx.lineTo(right, y); pctx.stroke();
    pctx.fillText(`${v}`, left - 4 * dpr, y + 3 * dpr);
  }
  const pts = pcSeries;
  if (!pts.length) {
    pctx.textAlign = 'center';
    pctx.fillText('no sorting progress on <metrics> yet', (left + right) / 2, (top + bottom) / 2);
    return;
  }
  const x0 = pts[0][0];
  const x1 = Math.max(pts[pts.length - 1][0], x0 + 1);
  const X = (s) => left + ((s - x0) / (x1 - x0)) * (right - left);
  const Y = (v) => bottom - (v / 100) * (bottom - top);
  pctx.beginPath();
  pts.forEach((p, i) => (i ? pctx.lineTo(X(p[0]), Y(p[1])) : pctx.moveTo(X(p[0]), Y(p[1]))));
  pctx.strokeStyle = '#2b6fe0';
  pctx.lineWidth = 2 * dpr;
  pctx.stroke();
  pctx.textAlign = 'left';
  pctx.fillStyle = '#6b7684';
  pctx.fillText(`step ${x0}`, left, H - 5 * dpr);
  pctx.textAlign = 'right';
  pctx.fillText(`step ${pts[pts.length - 1][0]}  PC ${pts[pts.length - 1][1].toFixed(1)} %`, right, H - 5 * dpr);
}

// ---- the frame loop and its rate -----------------------------------------
let fpsFrames = 0;
let fpsSince = performance.now();
function frame(now) {
  api.frames += 1;
  fpsFrames += 1;
  if (now - fpsSince >= 1000) {
    api.fps = (fpsFrames * 1000) / (now - fpsSince);
    $('fps').textContent = api.fps.toFixed(0);
    fpsFrames = 0;
    fpsSince = now;
  }
  // redrawEveryFrame (for a benchmark at the console): the whole arena each animation frame,
  // new data or not, to measure what drawing alone can hold.
  if (dirty || api.redrawEveryFrame) { dirty = false; draw(); }
  if (plotDirty) { plotDirty = false; drawPlot(); }
  requestAnimationFrame(frame);
}
requestAnimationFrame(frame);

// ---- the hub view ---------------------------------------------------------
function renderHub() {
  const h = hub;
  const parts = [];
  if (h.uptime !== null) {
    parts.push(`up ${h.uptime.toFixed(1)} s`, `lease ${h.lease} s`,
      `minimum priority ${h.min_priority === null ? 'none' : h.min_priority}`,
      `${h.client_count} client${h.client_count === 1 ? '' : 's'}`,
      `status ${h.status_age} s ago`);
    if (h.truncated) parts.push('(report cut to one datagram)');
  } else {
    parts.push('no status report yet');
  }
  if (h.bad_lines) parts.push(`${h.bad_lines} unreadable lines`);
  $('hub-summary').textContent = parts.join(' · ');
  const channels = {};
  const rank = (name) => ({ vision: 0, radio: 1, debug: 2, metrics: 3 }[name] ?? 4);
  const sorted = h.channels.slice().sort((a, b) => rank(a.name) - rank(b.name)
    || a.name.localeCompare(b.name, undefined, { numeric: true }));
  const rows = sorted.map((c) => {
    channels[c.name] = { rate: c.rate, packets: c.packets, last: c.last, age: c.last_age };
    const stale = c.last_age !== null && c.last_age * 1000 > STALE_MS;
    const cut = c.last !== null && c.last_len > c.last.length ? `\n… (${c.last_len} bytes)` : '';
    const last = c.last === null
      ? '<span class="age">not received</span>'
      : `<pre>${esc(c.last + cut)}</pre><span class="age">${c.last_age} s ago</span>`;
    return `<tr class="${stale ? 'stale' : ''}"><td class="name">${esc(c.name)}</td>`
      + `<td class="num">${c.rate === null ? '–' : c.rate.toFixed(1)}</td>`
      + `<td class="num">${c.in_status ? c.packets : '–'}</td><td>${last}</td></tr>`;
  });
  api.channels = channels;
  $('channels').tBodies[0].innerHTML = rows.join('') || '<tr><td colspan="4" class="hint">no channels yet</td></tr>';
  const clients = h.clients.map((c) => {
    const subs = c.subs.slice(0, 6).map((s) => esc(s[0])).join(', ') + (c.subs.length > 6 ? `, +${c.subs.length - 6} more` : '');
    return `<div title="${esc(c.subs.map((s) => s[0]).join(', '))}">${esc(c.addr)} · idle ${c.idle.toFixed(1)} s · ${subs || '(no subscriptions)'}</div>`;
  });
  if (h.clients_left_off) clients.push(`<div class="hint">and ${h.clients_left_off} more</div>`);
  $('clients').innerHTML = clients.join('') || '<div class="hint">none</div>';
  $('drops').innerHTML = h.drops.length
    ? h.drops.map((d) => `<div>${esc(d[0])}: ${d[1]}</div>`).join('')
    : '<div class="hint">none</div>';
}

// What the monitor turned away or dropped: refusals are someone knocking, and
// drops are Foxglove viewers missing messages; neither may go unseen.
function onMonitor(m) {
  api.monitor = m;
  const f = m.foxglove;
  const lines = [
    `web requests refused (another site, another host name, no token): ${m.refused}`,
    `Foxglove viewers: ${f.viewers} connected, ${f.refused} refused past the cap, `
      + `${f.dropped} messages dropped for slow ones, ${f.not_advertised} packets of topics past the channel list, `
      + `${f.scenes_skipped ?? 0} world frames whose arena scene was skipped to keep the monitor's time budget`,
  ];
  $('monitor-counts').innerHTML = lines.map((l) => `<div>${esc(l)}</div>`).join('');
}

// ---- selection and the override -------------------------------------------
function listIds(ids) {
  const shownIds = ids.slice(0, 16).join(', ');
  return `${ids.length === 1 ? 'robot' : 'robots'} ${shownIds}${ids.length > 16 ? ` and ${ids.length - 16} more` : ''}`;
}

function select(ids) {
  selected.clear();
  for (const id of ids) if (Number.isInteger(id) && id >= 0) selected.add(id);
  syncSelection();
}

function syncSelection() {
  api.selected = [...selected].sort((a, b) => a - b);
  $('sel-ids').value = api.selected.join(', ');
  dirty = true;
}

function parseIds(text) {
  const ids = [];
  for (const part of text.split(/[\s,;]+/)) {
    if (part === '') continue;
    const n = Number(part);
    if (!Number.isInteger(n) || n < 0 || n > 4294967295) return null;
    ids.push(n);
  }
  return ids;
}

$('sel-ids').addEventListener('change', () => {
  const ids = parseIds($('sel-ids').value);
  if (ids === null) { message('override-msg', 'robot ids are whole numbers, e.g. 0, 3', false); return; }
  select(ids);
});
$('sel-ids').addEventListener('keydown', (e) => { if (e.key === 'Enter') $('sel-ids').dispatchEvent(new Event('change')); });
$('sel-clear').onclick = () => select([]);

function chosenIds() {
  const ids = parseIds($('sel-ids').value);
  if (ids !== null && ids.join() !== api.selected.join()) select(ids);
  return api.selected;
}

$('take').onclick = () => {
  const ids = chosenIds();
  if (!ids.length) { message('override-msg', 'select robots first: click them, or type their ids', false); return; }
  send({ t: 'take', ids });
};
$('take-all').onclick = () => send({ t: 'take_all' });
$('release').onclick = () => {
  const ids = chosenIds();
  if (!ids.length) { message('override-msg', 'select the robots to release, or use Release all', false); return; }
  send({ t: 'release', ids });
};
$('release-all').onclick = () => send({ t: 'release_all' });

// The held robots a key or a click drives: the selected ones if any are held, else all held.
function drivenIds() {
  const held = new Set(api.held);
  const sel = api.selected.filter((id) => held.has(id));
  return sel.length ? sel : null;
}

// ---- pointer: pan, zoom, select, send ---------------------------------------
let press = null;
canvas.addEventListener('pointerdown', (e) => {
  press = { x: e.clientX, y: e.clientY, cx: view.cx, cy: view.cy, moved: false };
  canvas.setPointerCapture(e.pointerId);
  canvas.focus();
});
canvas.addEventListener('pointermove', (e) => {
  if (!press) return;
  const dx = e.clientX - press.x;
  const dy = e.clientY - press.y;
  if (Math.abs(dx) + Math.abs(dy) > 4) press.moved = true;
  if (press.moved) {
    view.auto = false;
    view.cx = press.cx - dx / view.scale;
    view.cy = press.cy + dy / view.scale;
    dirty = true;
  }
});
canvas.addEventListener('pointerup', (e) => {
  const p = press;
  press = null;
  if (!p || p.moved) return;
  click(e.clientX, e.clientY, e.shiftKey || e.ctrlKey || e.metaKey);
});
canvas.addEventListener('wheel', (e) => {
  e.preventDefault();
  view.auto = false;
  const before = clientToWorld(e.clientX, e.clientY);
  view.scale = Math.min(200, Math.max(0.02, view.scale * Math.exp(-e.deltaY * 0.0015)));
  const after = clientToWorld(e.clientX, e.clientY);
  view.cx += before.x - after.x;
  view.cy += before.y - after.y;
  dirty = true;
}, { passive: false });

function click(cx, cy, additive) {
  const w = world;
  if (!w) return;
  const at = clientToWorld(cx, cy);
  const reach = Math.max(sizes().robot_length * 0.8, 8 / view.scale);
  let hit = null;
  let best = Infinity;
  const b = bodies || EMPTY_BODIES;
  for (let i = 0; i < b.n; i++) {
    const d = Math.hypot(b.pose[3 * i] - at.x, b.pose[3 * i + 1] - at.y);
    if (d < reach && d < best) { best = d; hit = b.ids[i]; }
  }
  if (hit !== null) {
    if (additive) {
      if (selected.has(hit)) selected.delete(hit); else selected.add(hit);
    } else if (selected.size === 1 && selected.has(hit)) {
      selected.clear();
    } else {
      selected.clear();
      selected.add(hit);
    }
    syncSelection();
    return;
  }
  if (api.held.length) {
    send({ t: 'goto', ids: drivenIds(), x: tenth(at.x), y: tenth(at.y) });
  } else if (selected.size) {
    select([]);
  } else {
    message('override-msg', 'take control of a robot first, then click where it should go', false);
  }
}

// ---- keyboard driving ----------------------------------------------------
const KEYS = {
  ArrowUp: 'up', KeyW: 'up', ArrowDown: 'down', KeyS: 'down',
  ArrowLeft: 'left', KeyA: 'left', ArrowRight: 'right', KeyD: 'right',
};
const down = new Set();
let driveTimer = null;
function typing(e) {
  const t = e.target;
  return t && (t.tagName === 'INPUT' || t.tagName === 'TEXTAREA');
}
function driveNow() {
  const forward = (down.has('up') ? 0.8 : 0) - (down.has('down') ? 0.6 : 0);
  const turn = (down.has('left') ? 0.7 : 0) - (down.has('right') ? 0.7 : 0);
  if (!api.held.length) {
    message('override-msg', 'take control of a robot first, then drive it with the arrow keys', false);
    return;
  }
  send({ t: 'drive', ids: drivenIds(), forward, turn });
}
window.addEventListener('keydown', (e) => {
  const k = KEYS[e.code];
  if (!k || typing(e)) return;
  e.preventDefault();
  if (down.has(k)) return;
  down.add(k);
  driveNow();
  if (!driveTimer) driveTimer = setInterval(driveNow, 150);
});
window.addEventListener('keyup', (e) => {
  const k = KEYS[e.code];
  if (!k || !down.has(k)) return;
  down.delete(k);
  driveNow();
  if (!down.size && driveTimer) { clearInterval(driveTimer); driveTimer = null; }
});
window.addEventListener('blur', () => {
  if (down.size) { down.clear(); driveNow(); }
  if (driveTimer) { clearInterval(driveTimer); driveTimer = null; }
});

// ---- toolbar and the forge box --------------------------------------------
$('pause').onclick = () => {
  paused = !paused;
  api.paused = paused;
  $('pause').textContent = paused ? 'Resume view' : 'Pause view';
  $('pause').classList.toggle('on', paused);
  $('paused-note').hidden = !paused;
  if (!paused) { shown = world; shownBodies = bodies; }
  dirty = true;
};
$('fit').onclick = () => { view.auto = true; fit(); };
$('show-intents').onchange = () => { dirty = true; };
$('show-labels').onchange = () => { dirty = true; };
$('publish').onclick = () => {
  const text = $('forge').value;
  if (!text.trim()) { message('forge-msg', 'type a packet first: a header `@ <channel> 0`, then lines', false); return; }
  send({ t: 'publish', text });
};

resize();
connect();
