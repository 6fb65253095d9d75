// colony game: the strategy game's player client. Plain JavaScript, no library.
//
// The server sends {"t":"game"} (state, the last events, the last refusal)
// several times a second, {"t":"map"} when the battlefield changes, and
// {"t":"reply"} answers; the page sends {"t":"squad",...} orders. World
// coordinates are centimetres with y up, the map's bottom-left corner at the
// origin. window.colonyGame exposes what the page shows, for people at the
// console and for the browser tests. The socket, the view transform,
// escaping and the banners are common.js's, shared with the monitor page.
import {
  $, Transform, drawText, esc, fitBacking, serverLink, showBanners, showChip, showMessage, tenth, withToken,
} from './common.js';

const TEAM_COLOURS = { red: '#d63a2f', blue: '#2f6fd6', green: '#23a446', yellow: '#d6a21b' };
const SPARE_COLOURS = ['#8e44d6', '#e0702b', '#1fb5b5', '#d63384'];
// Moving AI characters: open, swamp, trees, out of bounds, water.
const TERRAIN = {
  '.': [238, 240, 230], G: [238, 240, 230], S: [150, 150, 72], T: [46, 94, 46],
  '@': [59, 63, 69], O: [59, 63, 69], W: [74, 134, 200],
};
const ROBOT_RADIUS_CM = 7; // the game's robots are 6 to 7.5 cm in radius
const KIND_LETTER = { scout: 'S', tank: 'T', infantry: 'I', amphibian: 'A' };

const canvas = $('field');
const ctx = canvas.getContext('2d', { alpha: false });

let game = null; // the newest {"t":"game"}
let map = null; // the newest map
let terrain = null; // the map drawn one pixel a cell
let team = new URLSearchParams(location.search).get('team') || null;
const teamFromUrl = team !== null;
let selected = null; // the selected squad's name
let dirty = true;
let link = null;
let connected = false;
let lastEventSeq = -1;
let lastRefusalSeq = -1;
let squadsKey = '';
const maxHealth = new Map(); // robot id -> the most health it has had

const api = {
  connected: false, state: null, map: null, mapVersion: 0, events: [], refusal: null,
  stale: true, team: null, selected: null, lastReply: null, lastCommand: null, frames: 0,
  worldToCanvas, worldToClient, clientToWorld, select, send, order,
  get formation() { return $('formation').value; },
};
window.colonyGame = api;

// The system monitor's page needs the token too.
$('monitor-link').href = withToken('/');

// ---- the connection -------------------------------------------------------
function connect() {
  link = serverLink('/ws?view=game', {
    onOpen() { connected = true; banners(); },
    onMessage(msg) {
      if (msg.t === 'game') onGame(msg);
      else if (msg.t === 'map') onMap(msg);
      else if (msg.t === 'reply') onReply(msg);
    },
    onClose() { connected = false; banners(); },
  });
}

function send(obj) {
  if (link && link.send(obj)) return true;
  message('not connected to the monitor server', false);
  return false;
}

// ---- incoming -------------------------------------------------------------
function onMap(m) {
  api.mapVersion = m.version;
  map = m.map;
  api.map = map && { width: map.width, height: map.height, cell: map.cell, sites: map.sites, version: m.version };
  terrain = map ? paintTerrain(map) : null;
  dirty = true;
}

function paintTerrain(m) {
  const img = document.createElement('canvas');
  img.width = m.width;
  img.height = m.height;
  const c = img.getContext('2d');
  const data = c.createImageData(m.width, m.height);
  for (let y = 0; y < m.height; y++) {
    const row = m.rows[y] || '';
    for (let x = 0; x < m.width; x++) {
      const rgb = TERRAIN[row[x]] || TERRAIN['@'];
      const i = (y * m.width + x) * 4;
      data.data[i] = rgb[0]; data.data[i + 1] = rgb[1]; data.data[i + 2] = rgb[2]; data.data[i + 3] = 255;
    }
  }
  c.putImageData(data, 0, 0);
  return img;
}

function onGame(g) {
  game = g;
  const s = g.state;
  api.state = s;
  api.stale = g.stale;
  api.events = g.events;
  api.refusal = g.refusal;
  if (s) {
    for (const r of s.robots) maxHealth.set(r.id, Math.max(maxHealth.get(r.id) || 0, r.health));
    chooseTeam(s);
  }
  header(g);
  renderSquads();
  renderEvents(g);
  renderRefusal(g.refusal);
  banners();
  dirty = true;
}

function onReply(r) {
  api.lastReply = r;
  message(r.msg, r.ok);
}

function message(text, ok) {
  showMessage($('game-msg'), text, ok);
}

// ---- the team the player commands -------------------------------------------
// ?team= in the URL wins; otherwise the first team that has robots.
function chooseTeam(s) {
  if (team === null) {
    const t = s.teams.find((t) => s.robots.some((r) => r.team === t.name));
    if (t) team = t.name;
  }
  api.team = team;
  const names = s.teams.map((t) => t.name);
  if (team !== null && !names.includes(team)) names.push(team);
  const sel = $('team');
  if (sel.dataset.key !== names.join(',')) {
    sel.dataset.key = names.join(',');
    sel.replaceChildren(...names.map((n) => {
      const o = document.createElement('option');
      o.value = n;
      o.textContent = n;
      return o;
    }));
  }
  if (team !== null && sel.value !== team) sel.value = team;
  $('team-note').textContent = team !== null && !s.teams.some((t) => t.name === team)
    ? `(no team ${team} in this game)` : (teamFromUrl ? '' : '(first team with robots)');
}

$('team').onchange = () => {
  team = $('team').value;
  api.team = team;
  select(null);
  squadsKey = '';
  renderSquads();
};

// ---- header, banners ---------------------------------------------------------
function colour(name) {
  if (TEAM_COLOURS[name]) return TEAM_COLOURS[name];
  const names = (game && game.state) ? game.state.teams.map((t) => t.name) : [];
  const i = Math.max(0, names.indexOf(name));
  return SPARE_COLOURS[i % SPARE_COLOURS.length];
}

function header(g) {
  const s = g.state;
  $('mode').textContent = s ? (s.mode === 'ctf' ? 'Capture the Flag' : s.mode === 'dm' ? 'Death Match' : s.mode) : '–';
  $('time').textContent = s ? `${s.time.toFixed(1)} s` : '–';
  $('status').textContent = s ? s.status : 'waiting for the game…';
  const score = $('score');
  const key = s ? JSON.stringify(s.teams) : '';
  if (score.dataset.key !== key) {
    score.dataset.key = key;
    score.replaceChildren(...(s ? s.teams : []).map((t) => {
      const el = document.createElement('span');
      el.className = 'team-chip';
      el.style.background = colour(t.name);
      el.dataset.team = t.name;
      el.textContent = `${t.name} ${t.score} · kills ${t.kills}`;
      return el;
    }));
  }
}

function banners() {
  api.connected = connected;
  const notes = [];
  if (!connected) notes.push({ cls: 'stale-banner server', text: 'monitor server lost: reconnecting…' });
  else if (game && game.stale) {
    notes.push({
      cls: 'stale-banner',
      text: game.state
        ? `game stale: no state on <game.state> for ${game.age} s`
        : 'no game yet: start one with `colony game ctf --player red`',
    });
  }
  const s = game && game.state;
  if (s && s.status === 'over') {
    notes.push({ cls: 'over-banner', text: `game over: ${s.winner ? `${s.winner} wins` : 'a draw'}${s.reason ? ` (${s.reason})` : ''}` });
  }
  showBanners($('banners'), notes);
  const live = !!(connected && game && !game.stale);
  showChip($('conn'), !connected ? 'server lost' : live ? 'live' : 'stale', live);
}

// ---- the side panel ------------------------------------------------------------
function healthBar(r) {
  const max = maxHealth.get(r.id) || r.health || 1;
  const f = Math.max(0, Math.min(1, r.health / max));
  const cls = f < 0.25 ? 'critical' : f < 0.5 ? 'low' : '';
  return `<span class="bar ${cls}" title="health ${r.health.toFixed(0)} of ${max.toFixed(0)}"><i style="width:${(f * 100).toFixed(0)}%"></i></span>`;
}

function renderSquads() {
  const s = game && game.state;
  const box = $('squads');
  if (!s) return;
  const squads = s.squads.filter((q) => q.team === team);
  const html = squads.map((q) => {
    const members = s.robots.filter((r) => r.team === q.team && r.squad === q.name);
    const alive = members.filter((r) => r.alive);
    const health = alive.reduce((a, r) => a + r.health, 0);
    const rows = members.map((r) => `<div class="robot${r.alive ? '' : ' dead'}" data-robot="${r.id}">`
      + `<span>#${r.id}</span><span>${esc(r.kind)}</span>${r.alive ? healthBar(r) : '<span>destroyed</span>'}`
      + `<span class="why" title="${esc(r.reason)}"><b>${esc(r.behaviour || '–')}</b>${r.reason ? ` — ${esc(r.reason)}` : ''}</span></div>`).join('');
    return `<div class="squad${q.name === selected ? ' selected' : ''}" data-squad="${esc(q.name)}" style="--team:${colour(q.team)}">`
      + `<div class="head"><b>${esc(q.name)}</b><span class="kv">${alive.length}/${members.length} robots · health <em>${health.toFixed(0)}</em></span>`
      + `<span class="kv">formation <em data-field="formation">${esc(q.formation)}</em></span></div>`
      + `<div class="kv">order <em data-field="order">${esc(q.order || 'none')}</em> · behaviour <em data-field="behaviour">${esc(q.behaviour || '–')}</em></div>`
      + `${rows}</div>`;
  }).join('');
  const enemies = s.teams.filter((t) => t.name !== team).map((t) => {
    const n = s.robots.filter((r) => r.team === t.name && r.alive).length;
    return `${esc(t.name)}: ${n} robot${n === 1 ? '' : 's'} standing`;
  });
  const full = (html || `<p class="hint">team ${esc(team ?? '–')} has no squads</p>`)
    + (enemies.length ? `<p class="enemy-note">${enemies.join(' · ')}</p>` : '');
  if (full !== squadsKey) {
    squadsKey = full;
    box.innerHTML = full;
  }
  if (selected !== null && !squads.some((q) => q.name === selected)) select(null);
}

// On press, not click: the list is rebuilt several times a second, and a
// click whose press and release land on different copies never fires.
$('squads').addEventListener('pointerdown', (e) => {
  const el = e.target.closest('[data-squad]');
  if (!el) return;
  select(el.dataset.squad === selected ? null : el.dataset.squad);
});

function renderEvents(g) {
  const last = g.events.length ? g.events[g.events.length - 1].seq : -1;
  if (last === lastEventSeq) return;
  lastEventSeq = last;
  const list = $('events');
  list.replaceChildren(...g.events.slice().reverse().map((e) => {
    const li = document.createElement('li');
    li.className = e.kind;
    li.innerHTML = `<span class="t">${e.time.toFixed(1)} s</span> <span class="k">${esc(e.kind)}</span> ${esc(e.text)}`;
    return li;
  }));
}

function renderRefusal(r) {
  const el = $('refusal');
  if (!r) { el.hidden = true; lastRefusalSeq = -1; return; }
  el.hidden = false;
  if (r.seq === lastRefusalSeq) return;
  lastRefusalSeq = r.seq;
  el.textContent = `refused at ${r.time.toFixed(1)} s: ${r.text}`;
  el.classList.remove('fresh');
  void el.offsetWidth; // restart the flash
  el.classList.add('fresh');
}

// ---- selection and orders --------------------------------------------------------
function select(squad) {
  selected = squad;
  api.selected = squad;
  for (const el of document.querySelectorAll('#squads [data-squad]')) {
    el.classList.toggle('selected', el.dataset.squad === squad);
  }
  // The list's HTML carries the selection too: rebuild it next time.
  squadsKey = '';
  $('selected-note').textContent = squad === null ? 'no squad selected' : `squad ${squad} selected`;
  dirty = true;
}

function order(fields) {
  if (team === null) { message('no team to command yet: wait for the game', false); return false; }
  if (selected === null) { message('select one of your squads first: click it in the list or on the map', false); return false; }
  const cmd = { t: 'squad', team, squad: selected, ...fields };
  const f = $('formation').value;
  if (f) cmd.formation = f;
  api.lastCommand = cmd;
  return send(cmd);
}

$('gather').onclick = () => order({ do: 'gather' });
$('stop').onclick = () => order({ do: 'stop' });
window.addEventListener('keydown', (e) => {
  if (e.key === 'Escape') select(null);
});

// ---- the view ------------------------------------------------------------------
function extent() {
  if (map) return { x0: 0, y0: 0, w: map.width * map.cell, h: map.height * map.cell };
  const s = game && game.state;
  let x0 = Infinity; let y0 = Infinity; let x1 = -Infinity; let y1 = -Infinity;
  const add = (x, y) => { x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y); };
  if (s) { for (const r of s.robots) add(r.x, r.y); for (const f of s.flags) add(f.x, f.y); }
  if (!(x1 > x0)) return { x0: 0, y0: 0, w: 500, h: 500 };
  const m = 50;
  return { x0: x0 - m, y0: y0 - m, w: x1 - x0 + 2 * m, h: Math.max(y1 - y0, 1) + 2 * m };
}

// World (cm, y up) to canvas device pixels: the whole battlefield, fitted.
function transform() {
  return Transform.fitted(canvas, extent(), 10);
}

/** World cm to canvas CSS pixels (relative to the canvas's top-left corner). */
function worldToCanvas(x, y) {
  return transform().toCanvas(x, y);
}

/** World cm to page client pixels, for a mouse click. */
function worldToClient(x, y) {
  return transform().toClient(x, y);
}

function clientToWorld(cx, cy) {
  return transform().fromClient(cx, cy);
}

function resize() {
  if (fitBacking(canvas)) dirty = true;
}
new ResizeObserver(resize).observe(canvas);

function draw() {
  const { k, ox, oy, dpr } = transform();
  const X = (x) => ox + x * k;
  const Y = (y) => oy - y * k;
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = '#2a2e33';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const s = game && game.state;
  if (map && terrain) {
    ctx.imageSmoothingEnabled = false;
    const c = map.cell;
    ctx.drawImage(terrain, X(0), Y(map.height * c), map.width * c * k, map.height * c * k);
    if (c * k >= 12 * dpr) grid(X, Y, k);
    for (const site of map.sites) drawSite(site, X, Y, k, dpr);
  }
  if (!s) {
    text(map ? 'waiting for the game state…' : 'waiting for the battlefield on <game.map>…',
      canvas.width / 2, canvas.height / 2, '#f2f4f7', 16 * dpr, 'center');
    return;
  }
  const r = Math.max(ROBOT_RADIUS_CM * k, 6 * dpr);
  // Planned paths: each squad's turn points as the game planned them; the
  // enemy's faint, since the player has no business following them.
  for (const q of s.squads) {
    if (q.path.length < 2) continue;
    const mine = q.team === team;
    ctx.beginPath();
    q.path.forEach(([px, py], i) => (i ? ctx.lineTo(X(px), Y(py)) : ctx.moveTo(X(px), Y(py))));
    ctx.strokeStyle = colour(q.team);
    ctx.globalAlpha = mine ? 0.9 : 0.35;
    ctx.lineWidth = (q.name === selected && mine ? 3 : 2) * dpr;
    ctx.setLineDash([8 * dpr, 5 * dpr]);
    ctx.stroke();
    ctx.setLineDash([]);
    const [ex, ey] = q.path[q.path.length - 1];
    ctx.beginPath();
    ctx.arc(X(ex), Y(ey), 4 * dpr, 0, 2 * Math.PI);
    ctx.fillStyle = colour(q.team);
    ctx.fill();
    ctx.globalAlpha = 1;
  }
  // Flags where they are now, ringed when carried.
  for (const f of s.flags) {
    const fx = X(f.x);
    const fy = Y(f.y);
    const h = Math.max(14 * dpr, 30 * k);
    ctx.strokeStyle = '#111';
    ctx.lineWidth = 2 * dpr;
    ctx.beginPath(); ctx.moveTo(fx, fy); ctx.lineTo(fx, fy - h); ctx.stroke();
    ctx.beginPath(); ctx.moveTo(fx, fy - h); ctx.lineTo(fx + h * 0.7, fy - h * 0.78); ctx.lineTo(fx, fy - h * 0.55); ctx.closePath();
    ctx.fillStyle = colour(f.team);
    ctx.fill();
    ctx.stroke();
    if (f.carrier !== null) {
      ctx.beginPath();
      ctx.arc(fx, fy, r + 6 * dpr, 0, 2 * Math.PI);
      ctx.strokeStyle = '#f2b705';
      ctx.lineWidth = 3 * dpr;
      ctx.setLineDash([4 * dpr, 3 * dpr]);
      ctx.stroke();
      ctx.setLineDash([]);
      text(`carried by #${f.carrier}`, fx + h * 0.75, fy - h * 0.6, '#fff', 11 * dpr, 'left', true);
    } else if (!f.home) {
      text('dropped', fx + h * 0.75, fy - h * 0.6, '#fff', 11 * dpr, 'left', true);
    }
  }
  // Robots: a disc in the team's colour, a heading tick, a health bar.
  for (const b of s.robots) {
    const bx = X(b.x);
    const by = Y(b.y);
    if (b.squad === selected && b.team === team && b.alive) {
      ctx.beginPath();
      ctx.arc(bx, by, r + 4 * dpr, 0, 2 * Math.PI);
      ctx.strokeStyle = '#f2b705';
      ctx.lineWidth = 3 * dpr;
      ctx.stroke();
    }
    ctx.beginPath();
    ctx.arc(bx, by, r, 0, 2 * Math.PI);
    ctx.fillStyle = b.alive ? colour(b.team) : '#7d848c';
    ctx.fill();
    ctx.strokeStyle = b.alive ? '#111' : '#4a5563';
    ctx.lineWidth = 1.2 * dpr;
    ctx.stroke();
    if (!b.alive) {
      ctx.beginPath();
      ctx.moveTo(bx - r * 0.6, by - r * 0.6); ctx.lineTo(bx + r * 0.6, by + r * 0.6);
      ctx.moveTo(bx - r * 0.6, by + r * 0.6); ctx.lineTo(bx + r * 0.6, by - r * 0.6);
      ctx.stroke();
      continue;
    }
    ctx.beginPath();
    ctx.moveTo(bx + Math.cos(b.theta) * r * 0.3, by - Math.sin(b.theta) * r * 0.3);
    ctx.lineTo(bx + Math.cos(b.theta) * (r + 5 * dpr), by - Math.sin(b.theta) * (r + 5 * dpr));
    ctx.strokeStyle = '#fff';
    ctx.lineWidth = 2.5 * dpr;
    ctx.stroke();
    const max = maxHealth.get(b.id) || b.health || 1;
    const f = Math.max(0, Math.min(1, b.health / max));
    const bw = Math.max(2 * r, 16 * dpr);
    const top = by - r - 8 * dpr;
    ctx.fillStyle = 'rgba(0,0,0,0.55)';
    ctx.fillRect(bx - bw / 2, top, bw, 4 * dpr);
    ctx.fillStyle = f < 0.25 ? '#d63a2f' : f < 0.5 ? '#e0a21b' : '#3bd16f';
    ctx.fillRect(bx - bw / 2, top, bw * f, 4 * dpr);
    if (r >= 7 * dpr) text(KIND_LETTER[b.kind] || '?', bx, by + 4 * dpr, '#fff', 10 * dpr, 'center');
    text(`${b.id}`, bx + r + 2 * dpr, by + r + 8 * dpr, '#fff', 10 * dpr, 'left', true);
  }
}

function grid(X, Y, k) {
  ctx.beginPath();
  const c = map.cell;
  for (let x = 0; x <= map.width; x++) { ctx.moveTo(X(x * c), Y(0)); ctx.lineTo(X(x * c), Y(map.height * c)); }
  for (let y = 0; y <= map.height; y++) { ctx.moveTo(X(0), Y(y * c)); ctx.lineTo(X(map.width * c), Y(y * c)); }
  ctx.strokeStyle = 'rgba(0,0,0,0.06)';
  ctx.lineWidth = 1;
  ctx.stroke();
}

function drawSite(site, X, Y, k, dpr) {
  const half = Math.max(map.cell * 1.5, 20) * k;
  const [bx, by] = site.base;
  ctx.fillStyle = colour(site.team);
  ctx.globalAlpha = 0.22;
  ctx.fillRect(X(bx) - half, Y(by) - half, 2 * half, 2 * half);
  ctx.globalAlpha = 1;
  ctx.strokeStyle = colour(site.team);
  ctx.lineWidth = 2 * dpr;
  ctx.strokeRect(X(bx) - half, Y(by) - half, 2 * half, 2 * half);
  text(`${site.team} base`, X(bx), Y(by) + half + 12 * dpr, colour(site.team), 11 * dpr, 'center', true);
  // The flag's stand, where a returned flag goes.
  const [fx, fy] = site.flag;
  ctx.beginPath();
  ctx.arc(X(fx), Y(fy), Math.max(5 * dpr, 10 * k), 0, 2 * Math.PI);
  ctx.setLineDash([3 * dpr, 3 * dpr]);
  ctx.stroke();
  ctx.setLineDash([]);
}

function text(s, x, y, fill, px, align, halo) {
  drawText(ctx, s, x, y, { fill, px, align, halo });
}

// ---- clicks on the battlefield ------------------------------------------------------
// What lies under a click: the nearest robot or flag within reach, or the
// player's own base, or nothing.
function hit(at) {
  const s = game && game.state;
  if (!s) return null;
  const { k, dpr } = transform();
  const reach = Math.max(ROBOT_RADIUS_CM * 1.8, (12 * dpr) / k);
  let best = null;
  let bestD = Infinity;
  for (const b of s.robots) {
    if (!b.alive) continue;
    const d = Math.hypot(b.x - at.x, b.y - at.y);
    if (d < reach && d < bestD) { bestD = d; best = { robot: b }; }
  }
  const flagReach = Math.max(25, (16 * dpr) / k);
  for (const f of s.flags) {
    const d = Math.hypot(f.x - at.x, f.y - at.y);
    // A robot standing on a flag is the flag's carrier or guard: the flag wins only when clearly nearer.
    if (d < flagReach && d + 4 < bestD) { bestD = d; best = { flag: f }; }
  }
  if (best) return best;
  if (map) {
    for (const site of map.sites) {
      const half = Math.max(map.cell * 1.5, 20);
      if (Math.abs(site.base[0] - at.x) <= half && Math.abs(site.base[1] - at.y) <= half) return { base: site.team };
    }
  }
  return null;
}

function click(e) {
  const s = game && game.state;
  if (!s) return;
  const at = clientToWorld(e.clientX, e.clientY);
  const h = hit(at);
  if (h && h.robot && h.robot.team === team && (selected === null || h.robot.squad === selected)) {
    select(h.robot.squad === selected ? null : h.robot.squad);
    return;
  }
  if (selected === null) {
    message('select one of your squads first: click it in the list or one of its robots', false);
    return;
  }
  if (h && h.robot) {
    order(h.robot.team === team ? { do: 'defend', robot: h.robot.id } : { do: 'attack', robot: h.robot.id });
  } else if (h && h.flag) {
    order(h.flag.team === team ? { do: 'defend', flag: h.flag.team } : { do: 'capture', flag: h.flag.team });
  } else if (h && h.base === team) {
    order({ do: 'defend', base: team });
  } else if (e.shiftKey) {
    order({ do: 'attack', x: tenth(at.x), y: tenth(at.y) });
  } else {
    order({ do: 'goto', x: tenth(at.x), y: tenth(at.y) });
  }
}

canvas.addEventListener('click', click);

// ---- the frame loop -------------------------------------------------------------
function frame() {
  if (dirty) {
    dirty = false;
    draw();
    api.frames += 1;
  }
  requestAnimationFrame(frame);
}
setInterval(banners, 500);
resize();
requestAnimationFrame(frame);
connect();
