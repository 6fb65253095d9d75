// colony game: the strategy game's player client. Plain JavaScript, no library.
//
// The server sends {"t":"game"} (state, the last events, the last refusal)
// several times a second, {"t":"map"} when the battlefield changes, {"t":"chat"}
// with the chat of the team this page plays, and {"t":"reply"} answers; the page
// sends {"t":"squad"} and {"t":"robot"} orders, {"t":"split"}, {"t":"merge"},
// {"t":"robot_drive"} and {"t":"robot_release"} for direct control, and {"t":"chat"}. World
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
// The legend's words for the map's characters, one entry a colour.
const TERRAIN_NAMES = [
  [['.', 'G'], 'open ground'], [['S'], 'swamp (slow)'], [['T'], 'trees (blocks sight)'],
  [['W'], 'water (amphibians only)'], [['@', 'O'], 'wall or out of bounds'],
];
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
let picked = null; // the selected robot's id (orders go to it alone)
let driving = null; // the robot driven with the keys
const keys = new Set(); // the driving keys held
let stroke = null; // a path being drawn: world points
let press = null; // where a press on the battlefield began
let hover = null; // the id of the robot under the pointer
let suppressClick = false;
let chatLines = [];
let lastChatSeq = -1;
const player = new URLSearchParams(location.search).get('name') || 'player';
let audio = null;
let eventsPrimed = false; // a game message came since the socket opened
let dirty = true;
let link = null;
let connected = false;
let lastEventSeq = -1;
let lastRefusalSeq = -1;
let squadsKey = '';
const maxHealth = new Map(); // robot id -> the most health it has had

const api = {
  connected: false, state: null, map: null, mapVersion: 0, events: [], refusal: null,
  stale: true, heard: null, prematch: false, commandable: true, team: null, selected: null, picked: null, driving: null, lastReply: null, lastCommand: null,
  frames: 0, chat: [], sounds: [], labels: [], legend: [],
  worldToCanvas, worldToClient, clientToWorld, select, pick, send, order,
  get formation() { return $('formation').value; },
};
window.colonyGame = api;

// A page opened for a team stays that team's: switching would only ask for another's view.
$('team').disabled = teamFromUrl;

// The system monitor's page needs the token too.
$('monitor-link').href = withToken('/');

// ---- the connection -------------------------------------------------------
function socketPath() {
  return team === null ? '/ws?view=game' : `/ws?view=game&team=${encodeURIComponent(team)}`;
}

function connect() {
  link = serverLink(socketPath(), {
    onOpen() { connected = true; eventsPrimed = false; banners(); },
    onMessage(msg) {
      if (msg.t === 'game') onGame(msg);
      else if (msg.t === 'map') onMap(msg);
      else if (msg.t === 'chat') onChat(msg);
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
  legend(map);
  dirty = true;
}

/** The terrain's legend: only the kinds this map has, in the colours it is drawn in. */
function legend(m) {
  const present = new Set(m ? m.rows.join('') : '');
  const items = TERRAIN_NAMES.filter(([chars]) => chars.some((c) => present.has(c)));
  api.legend = items.map(([, name]) => name);
  $('legend').replaceChildren(...items.map(([chars, name]) => {
    const li = document.createElement('li');
    const sw = document.createElement('i');
    sw.style.background = `rgb(${TERRAIN[chars[0]].join(',')})`;
    li.append(sw, name);
    return li;
  }));
  $('legend').hidden = !items.length;
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
  prematch(g.lobby);
  const s = g.state;
  api.state = s;
  api.stale = g.stale;
  api.prematch = !!g.prematch;
  api.heard = g.heard === undefined ? null : g.heard;
  api.events = g.events;
  api.refusal = g.refusal;
  if (s) {
    for (const r of s.robots) maxHealth.set(r.id, Math.max(maxHealth.get(r.id) || 0, r.max_health || 0, r.health));
    chooseTeam(s);
  }
  header(g);
  renderSquads();
  renderEvents(g);
  renderRefusal(g.refusal);
  banners();
  dirty = true;
}

function onChat(c) {
  if (c.team !== team) return;
  const fresh = c.lines.filter((l) => l.seq > lastChatSeq);
  if (!c.backlog && fresh.length && $('chat-on').checked) beep('chat');
  if (c.lines.length) lastChatSeq = Math.max(lastChatSeq, ...c.lines.map((l) => l.seq));
  chatLines = c.lines;
  api.chat = c.lines.map((l) => ({ from: l.from, text: l.text }));
  $('chat').replaceChildren(...c.lines.map((l) => {
    const li = document.createElement('li');
    li.innerHTML = `<span class="from">${esc(l.from)}</span>: ${esc(l.text)}`;
    return li;
  }));
  $('chat').scrollTop = $('chat').scrollHeight;
}

$('chat-form').addEventListener('submit', (e) => {
  e.preventDefault();
  const text = $('chat-text').value.trim();
  if (!text) return;
  if (team === null) { message('no team to chat with yet: wait for the game', false); return; }
  if (send({ t: 'chat', team, from: player, text })) $('chat-text').value = '';
});

// ---- the pre-match: budget, types, health and power, squads ----------------------------
// The draft is what this page edits; it starts from the team's setup as the lobby has it and
// goes back to the game (as `--red` writes it: alpha:tank+h2+p1,scout) when the player is ready.
let draft = null;
let draftFrom = null;
let edited = false; // the player changed the draft since the lobby last took it
let sentSetup = null; // the setup last sent: the draft is the lobby's again once it shows it

function parseSetup(text) {
  return text.split(/\s+/).filter(Boolean).map((part) => {
    const [name, robots = ''] = part.split(':');
    return {
      name,
      robots: robots.split(',').filter(Boolean).map((b) => {
        const [kind, ...ups] = b.split('+');
        const r = { kind, health: 0, power: 0 };
        for (const u of ups) {
          if (u[0] === 'h') r.health = Number(u.slice(1)) || 0;
          if (u[0] === 'p') r.power = Number(u.slice(1)) || 0;
        }
        return r;
      }),
    };
  });
}

function setupText(d) {
  return d.map((q) => `${q.name}:${q.robots.map((r) => r.kind + (r.health ? `+h${r.health}` : '') + (r.power ? `+p${r.power}` : '')).join(',')}`).join(' ');
}

function draftCost(l) {
  const price = new Map(l.kinds.map((k) => [k.kind, k.cost]));
  return draft.reduce((a, q) => a + q.robots.reduce((b, r) => b + (price.get(r.kind) || 0) + r.health + r.power, 0), 0);
}

function prematch(l) {
  api.lobby = l || null;
  const show = !!(l && l.status === 'drafting' && !(game && game.state));
  $('prematch').hidden = !show;
  if (!show) return;
  const mine = team === null ? null : l.teams.find((t) => t.name === team);
  if (mine && edited && mine.setup === sentSetup) edited = false;
  if (mine && !mine.bot && (draft === null || (!edited && mine.setup !== draftFrom))) {
    draft = parseSetup(mine.setup);
    draftFrom = mine.setup;
    renderDraft(l);
  }
  $('pm-step').textContent = Math.round(l.upgrade * 100);
  $('pm-budget').textContent = l.budget;
  if (draft) {
    const cost = draftCost(l);
    $('pm-cost').textContent = cost;
    $('pm-cost').classList.toggle('over', cost > l.budget);
  }
  $('pm-ready').disabled = !mine || mine.bot;
  $('pm-ready').textContent = mine && mine.ready ? 'Ready ✓ (change to edit)' : 'Ready';
  const teams = l.teams.map((t) => `<li>${esc(t.name)}: ${t.ready ? 'ready' : 'setting up'}${t.bot ? ' (built-in player)' : ''} · ${t.cost} points</li>`).join('');
  if ($('pm-teams').dataset.key !== teams) {
    $('pm-teams').dataset.key = teams;
    $('pm-teams').innerHTML = teams;
  }
}

function renderDraft(l) {
  const kinds = l.kinds.map((k) => k.kind);
  const describe = (k) => `${k.kind}: ${k.cost} points, health ${k.health}, power ${k.power}, speed ${k.speed} cm/s, range ${k.range} cm${k.amphibious ? ', crosses water' : ''}`;
  $('pm-squads').innerHTML = draft.map((q, i) => `<div class="pm-squad" data-i="${i}">`
    + `<label>squad <input class="pm-name" value="${esc(q.name)}" maxlength="32" aria-label="squad name"></label> `
    + `<button type="button" class="pm-del-squad">remove squad</button>`
    + q.robots.map((r, k) => `<div class="pm-robot" data-k="${k}">`
      + `<select class="pm-kind" aria-label="robot type">${l.kinds.map((o) => `<option value="${esc(o.kind)}" title="${esc(describe(o))}"${o.kind === r.kind ? ' selected' : ''}>${esc(o.kind)} · ${o.cost}</option>`).join('')}</select>`
      + `<label title="health points bought">health +<input type="number" class="pm-health" min="0" max="${l.max_upgrade}" value="${r.health}"></label>`
      + `<label title="power points bought">power +<input type="number" class="pm-power" min="0" max="${l.max_upgrade}" value="${r.power}"></label>`
      + `<button type="button" class="pm-del" aria-label="remove this robot">×</button></div>`).join('')
    + `<button type="button" class="pm-add-robot">+ robot</button></div>`).join('');
  if (!kinds.length) $('pm-squads').textContent = 'waiting for the robot types…';
}

function draftChanged() {
  edited = true;
  if (game && game.lobby) prematch(game.lobby);
}

$('pm-squads').addEventListener('input', (e) => {
  const box = e.target.closest('.pm-squad');
  if (!box || !draft) return;
  const q = draft[Number(box.dataset.i)];
  const row = e.target.closest('.pm-robot');
  if (e.target.classList.contains('pm-name')) q.name = e.target.value.trim();
  else if (row) {
    const r = q.robots[Number(row.dataset.k)];
    if (e.target.classList.contains('pm-kind')) r.kind = e.target.value;
    if (e.target.classList.contains('pm-health')) r.health = Math.max(0, Math.round(Number(e.target.value) || 0));
    if (e.target.classList.contains('pm-power')) r.power = Math.max(0, Math.round(Number(e.target.value) || 0));
  }
  draftChanged();
});

$('pm-squads').addEventListener('click', (e) => {
  const box = e.target.closest('.pm-squad');
  if (!box || !draft || !game || !game.lobby) return;
  const i = Number(box.dataset.i);
  if (e.target.classList.contains('pm-add-robot')) draft[i].robots.push({ kind: game.lobby.kinds[0].kind, health: 0, power: 0 });
  else if (e.target.classList.contains('pm-del')) draft[i].robots.splice(Number(e.target.closest('.pm-robot').dataset.k), 1);
  else if (e.target.classList.contains('pm-del-squad')) draft.splice(i, 1);
  else return;
  renderDraft(game.lobby);
  draftChanged();
});

$('pm-add-squad').onclick = () => {
  if (!draft || !game || !game.lobby) return;
  const names = new Set(draft.map((q) => q.name));
  let k = draft.length + 1;
  while (names.has(`squad${k}`)) k += 1;
  draft.push({ name: `squad${k}`, robots: [{ kind: game.lobby.kinds[0].kind, health: 0, power: 0 }] });
  renderDraft(game.lobby);
  draftChanged();
};

// Ready sends the setup with it: a setup the rules refuse is never ready (the refusal says why).
$('pm-ready').onclick = () => {
  if (!draft || team === null) return;
  const squads = setupText(draft);
  // Kept as drawn until the lobby shows it taken: a refused setup is not lost.
  edited = true;
  sentSetup = squads;
  draftFrom = squads;
  sendCommand({ t: 'setup', team, squads, ready: true });
};

// ---- sounds: synthesised in the page, no files ----------------------------------
const TONES = {
  hit: [660, 0.05, 'square'],
  destroyed: [110, 0.35, 'sawtooth'],
  'flag-taken': [880, 0.15, 'triangle'],
  'flag-dropped': [330, 0.2, 'triangle'],
  'flag-returned': [550, 0.2, 'triangle'],
  captured: [1320, 0.3, 'triangle'],
  refused: [180, 0.2, 'square'],
  over: [440, 0.6, 'triangle'],
  chat: [990, 0.06, 'sine'],
};
// Both switches are remembered by the browser.
for (const [id, key] of [['sound', 'colony-game-sound'], ['chat-on', 'colony-game-chat']]) {
  $(id).checked = localStorage.getItem(key) !== 'off';
  $(id).addEventListener('change', () => localStorage.setItem(key, $(id).checked ? 'on' : 'off'));
}
const showChat = () => { $('chat-section').hidden = !$('chat-on').checked; };
$('chat-on').addEventListener('change', showChat);
showChat();

function beep(kind) {
  const tone = TONES[kind];
  if (!tone || !$('sound').checked) return;
  try {
    audio = audio || new AudioContext();
  } catch (e) {
    return;
  }
  const [hz, secs, type] = tone;
  const t = audio.currentTime;
  const osc = audio.createOscillator();
  const gain = audio.createGain();
  osc.type = type;
  osc.frequency.value = hz;
  gain.gain.setValueAtTime(0.08, t);
  gain.gain.exponentialRampToValueAtTime(0.0001, t + secs);
  osc.connect(gain).connect(audio.destination);
  osc.start(t);
  osc.stop(t + secs);
  api.sounds.push(kind);
  if (api.sounds.length > 50) api.sounds.shift();
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
  if (link) link.setPath(socketPath());
  const names = s.teams.map((t) => t.name);
  if (team !== null && !names.includes(team)) names.push(team);
  const sel = $('team');
  fillSelect(sel, names);
  if (team !== null && sel.value !== team) sel.value = team;
  $('team-note').textContent = team !== null && !s.teams.some((t) => t.name === team)
    ? `(no team ${team} in this game)` : (teamFromUrl ? '' : '(first team with robots)');
}

/** Gives a select these names as options when they changed, keeping the choice while it is one. */
function fillSelect(sel, names) {
  const key = names.join(',');
  if (sel.dataset.key === key) return;
  const keep = sel.value;
  sel.dataset.key = key;
  sel.replaceChildren(...names.map((n) => {
    const o = document.createElement('option');
    o.value = n;
    o.textContent = n;
    return o;
  }));
  if (names.includes(keep)) sel.value = keep;
}

$('team').onchange = () => {
  if (driving !== null) stopDriving();
  team = $('team').value;
  api.team = team;
  chatLines = [];
  lastChatSeq = -1;
  draft = null;
  edited = false;
  $('chat').replaceChildren();
  link.setPath(socketPath());
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

// Nothing on the wire marks a replayed log (`colony replay`) as one, but a replay has no game
// server reading the teams' orders: the monitor says so (`heard`, from the hub's status), and
// this page then says "replay" rather than "live" and hides the commands nobody would obey.
function unheard() {
  return !!(game && game.heard === false);
}

function banners() {
  api.connected = connected;
  const notes = [];
  const prematch = !!(game && game.prematch);
  if (!connected) notes.push({ cls: 'stale-banner server', text: 'monitor server lost: reconnecting…' });
  else if (prematch && !game.stale) {
    notes.push({ cls: 'info-banner', text: 'pre-match: set up your team and press Ready; the match starts when every team is ready' });
  } else if (game && game.stale) {
    notes.push({
      cls: 'stale-banner',
      text: game.state
        ? `game stale: no state on <game.state> for ${game.age} s`
        : prematch ? 'pre-match stale: no word from the lobby on <game.lobby>'
          : 'no game yet: start one with `colony game ctf --player red`',
    });
  }
  if (connected && game && !game.stale && unheard()) {
    notes.push({
      cls: 'info-banner',
      text: `no game is reading ${team === null ? 'any team\'s' : `${team}'s`} orders: a replayed log (colony replay) or a match whose game server has gone; commands are hidden`,
    });
  }
  const s = game && game.state;
  if (s && s.status === 'over') {
    notes.push({ cls: 'over-banner', text: `game over: ${s.winner ? `${s.winner} wins` : 'a draw'}${s.reason ? ` (${s.reason})` : ''}` });
  }
  showBanners($('banners'), notes);
  const fresh = !!(connected && game && !game.stale);
  api.commandable = !unheard();
  $('commands').hidden = unheard();
  if (!connected) showChip($('conn'), 'server lost', false);
  else if (fresh && prematch) showChip($('conn'), 'pre-match', null);
  else if (fresh && unheard()) showChip($('conn'), 'replay: orders unheard', null);
  else if (fresh) showChip($('conn'), 'live', true);
  else showChip($('conn'), 'stale', false);
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
    const rows = members.map((r) => `<div class="robot${r.alive ? '' : ' dead'}${r.id === picked ? ' picked' : ''}${r.id === driving ? ' driven' : ''}" data-robot="${r.id}">`
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
  fillSelect($('merge-into'), squads.map((q) => q.name).filter((n) => n !== selected));
  if (selected !== null && !squads.some((q) => q.name === selected)) select(null);
  if (picked !== null && !s.robots.some((r) => r.id === picked && r.team === team && r.alive)) pick(null);
}

// On press, not click: the list is rebuilt several times a second, and a
// click whose press and release land on different copies never fires.
$('squads').addEventListener('pointerdown', (e) => {
  const row = e.target.closest('[data-robot]');
  if (row && !row.classList.contains('dead')) {
    const id = Number(row.dataset.robot);
    pick(id === picked ? null : id);
    return;
  }
  const el = e.target.closest('[data-squad]');
  if (!el) return;
  select(el.dataset.squad === selected ? null : el.dataset.squad);
});

function renderEvents(g) {
  const last = g.events.length ? g.events[g.events.length - 1].seq : -1;
  // A sound for each kind of news, not for the backlog the first message after connecting brings.
  const primed = eventsPrimed;
  eventsPrimed = true;
  if (last === lastEventSeq) return;
  if (primed) {
    const kinds = new Set(g.events.filter((e) => e.seq > lastEventSeq).map((e) => e.kind));
    for (const k of kinds) beep(k);
  }
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
  if (squad !== null) setPicked(null);
  for (const el of document.querySelectorAll('#squads [data-squad]')) {
    el.classList.toggle('selected', el.dataset.squad === squad);
  }
  // The list's HTML carries the selection too: rebuild it next time.
  squadsKey = '';
  note();
  dirty = true;
}

function setPicked(id) {
  if (driving !== null && id !== driving) stopDriving();
  picked = id;
  api.picked = id;
}

/** Selects one robot of the player's (null: none); orders then go to it alone. */
function pick(id) {
  if (id !== null) { selected = null; api.selected = null; }
  setPicked(id);
  squadsKey = '';
  renderSquads();
  note();
  dirty = true;
}

function note() {
  $('selected-note').textContent = picked !== null
    ? `robot ${picked} selected${driving === picked ? ': driving (arrows or WASD, Esc to give it back)' : ''}`
    : selected === null ? 'no squad selected' : `squad ${selected} selected`;
  $('drive').classList.toggle('on', driving !== null);
  $('drive').textContent = driving !== null ? `Release ${driving}` : 'Drive';
}

function order(fields) {
  if (team === null) { message('no team to command yet: wait for the game', false); return false; }
  let cmd;
  if (picked !== null) {
    cmd = { t: 'robot', team, id: picked, ...fields };
  } else if (selected !== null) {
    cmd = { t: 'squad', team, squad: selected, ...fields };
    const f = $('formation').value;
    if (f) cmd.formation = f;
  } else {
    message('select one of your squads (or one robot) first: click it in the list or on the map', false);
    return false;
  }
  api.lastCommand = cmd;
  return send(cmd);
}

function sendCommand(cmd) {
  if (unheard()) { message('no game is reading these orders (a replay?): nothing was sent', false); return false; }
  api.lastCommand = cmd;
  return send(cmd);
}

$('gather').onclick = () => order({ do: 'gather' });
$('stop').onclick = () => order({ do: 'stop' });

// A free name for a squad split off `name`: name-2, name-3, ... within the 32 characters a name may have.
function splitName(name) {
  const s = game && game.state;
  const taken = new Set(s ? s.squads.filter((q) => q.team === team).map((q) => q.name) : []);
  for (let k = 2; k < 1000; k++) {
    const tail = `-${k}`;
    const n = name.slice(0, 32 - tail.length) + tail;
    if (!taken.has(n)) return n;
  }
  return null;
}

$('split').onclick = () => {
  const s = game && game.state;
  if (!s || selected === null) { message('select the squad to split first', false); return; }
  const alive = s.robots.filter((r) => r.team === team && r.squad === selected && r.alive).map((r) => r.id);
  if (alive.length < 2) { message(`squad ${selected} has fewer than two robots standing: nothing to split`, false); return; }
  const robots = alive.slice(Math.ceil(alive.length / 2));
  sendCommand({ t: 'split', team, squad: selected, robots, into: splitName(selected) });
};

$('merge').onclick = () => {
  const into = $('merge-into').value;
  if (selected === null) { message('select the squad to merge first', false); return; }
  if (!into) { message('choose the squad to merge into', false); return; }
  sendCommand({ t: 'merge', team, squad: selected, into });
};

// ---- direct control of one robot -------------------------------------------------------
// By key position (e.code), so Shift or a keyboard layout cannot leave a key held.
const DRIVE_KEYS = {
  ArrowUp: [1, 0], KeyW: [1, 0],
  ArrowDown: [-1, 0], KeyS: [-1, 0],
  ArrowLeft: [0, 1], KeyA: [0, 1],
  ArrowRight: [0, -1], KeyD: [0, -1],
};
// Keys typed into a text or number field are the field's, not the robot's.
const typing = (e) => (e.target instanceof HTMLInputElement && e.target.type !== 'checkbox')
  || e.target instanceof HTMLTextAreaElement;

function steer() {
  let forward = 0;
  let turn = 0;
  for (const k of keys) { forward += DRIVE_KEYS[k][0]; turn += DRIVE_KEYS[k][1]; }
  const clamp = (v) => Math.max(-1, Math.min(1, v));
  return { forward: clamp(forward), turn: clamp(turn) };
}

function startDriving() {
  if (picked === null) { message('select one robot to drive: its row in the list, or ctrl-click it', false); return; }
  driving = picked;
  api.driving = driving;
  // Taking control stops the robot where it is, until a key says otherwise.
  sendCommand({ t: 'robot_drive', team, robot: driving, forward: 0, turn: 0 });
  note();
  squadsKey = '';
  renderSquads();
}

function stopDriving() {
  const robot = driving;
  driving = null;
  api.driving = null;
  keys.clear();
  if (robot !== null) sendCommand({ t: 'robot_release', team, robot });
  note();
  squadsKey = '';
}

$('drive').onclick = () => (driving === null ? startDriving() : stopDriving());

// While keys are held, their wheels five times a second: each holds the robot's wheels for half a
// second, so a closed page or a lost packet leaves it standing.
setInterval(() => {
  if (driving === null || keys.size === 0) return;
  sendCommand({ t: 'robot_drive', team, robot: driving, ...steer() });
}, 200);

window.addEventListener('keydown', (e) => {
  if (typing(e)) return;
  if (e.key === 'Escape') {
    if (driving !== null) stopDriving();
    else { select(null); pick(null); }
    return;
  }
  if (driving !== null && DRIVE_KEYS[e.code]) {
    e.preventDefault();
    if (!keys.has(e.code)) {
      keys.add(e.code);
      sendCommand({ t: 'robot_drive', team, robot: driving, ...steer() });
    }
  }
});
window.addEventListener('keyup', (e) => {
  if (!DRIVE_KEYS[e.code] || !keys.has(e.code)) return;
  keys.delete(e.code);
  if (driving !== null) sendCommand({ t: 'robot_drive', team, robot: driving, ...steer() });
});
window.addEventListener('blur', () => keys.clear());
// A closing page gives its robot back (the game takes it back anyway 2 s after the last key).
window.addEventListener('pagehide', () => { if (driving !== null) stopDriving(); });

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
  const labels = new Labels(dpr);
  if (!s) {
    siteLabels(labels, X, Y, k, dpr);
    text(map ? (game && game.prematch ? 'the battlefield: the match starts when every team is ready'
      : 'waiting for the game state…') : 'waiting for the battlefield on <game.map>…',
    canvas.width / 2, map ? 24 * dpr : canvas.height / 2, '#f2f4f7', 16 * dpr, 'center', true);
    return;
  }
  const r = Math.max(ROBOT_RADIUS_CM * k, 6 * dpr);
  // Planned paths: each squad's turn points as the game planned them. A team's page is not
  // even sent another team's (the server cuts them); a page that picked a team by itself
  // still shows only that team's, faint enemy plans being a spectator's view alone.
  for (const q of s.squads) {
    if (q.path.length < 2) continue;
    const mine = q.team === team;
    if (!mine && team !== null) continue;
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
  // Labels are placed where they hide neither a robot nor another label: base names first (they
  // are drawn last, over the robots), then robot ids; an id with no free place is shown only
  // for the robot under the pointer or selected.
  for (const b of s.robots) if (b.alive) labels.block(X(b.x) - r, Y(b.y) - r - 8 * dpr, 2 * r, 2 * r + 8 * dpr);
  const bases = siteBoxes(labels, X, Y, k, dpr);
  const ids = [];
  // Robots: a disc in the team's colour, a heading tick, a health bar.
  for (const b of s.robots) {
    const bx = X(b.x);
    const by = Y(b.y);
    if (((b.squad === selected && picked === null) || b.id === picked) && b.team === team && b.alive) {
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
    ids.push(b);
  }
  // The pointed and selected robots' labels first, so theirs get a place.
  const wanted = (b) => b.id === hover || b.id === picked || (b.squad === selected && b.team === team);
  ids.sort((a, b) => wanted(b) - wanted(a));
  for (const b of ids) {
    const bx = X(b.x);
    const by = Y(b.y);
    const at = labels.place(`${b.id}`, 10 * dpr, [
      [bx + r + 2 * dpr, by + r + 8 * dpr], [bx + r + 2 * dpr, by - r - 2 * dpr],
      [bx - r - 2 * dpr, by + r + 8 * dpr, 'right'], [bx - r - 2 * dpr, by - r - 2 * dpr, 'right'],
    ], wanted(b));
    if (at) text(`${b.id}`, at[0], at[1], '#fff', 10 * dpr, at[2] || 'left', true);
  }
  for (const l of bases) text(l.text, l.x, l.y, l.fill, l.px, 'center', true);
  api.labels = labels.shown;
  drawStroke(X, Y, dpr);
}

/** Where labels went, so that none hides another or a robot. */
class Labels {
  constructor(dpr) {
    this.dpr = dpr;
    this.taken = []; // [x0, y0, x1, y1], device pixels
    this.shown = []; // {text, x0, y0, x1, y1}
  }

  block(x, y, w, h) {
    this.taken.push([x, y, x + w, y + h]);
  }

  free(b) {
    return !this.taken.some((t) => b[0] < t[2] && t[0] < b[2] && b[1] < t[3] && t[1] < b[3]);
  }

  /** The first candidate [x, y(baseline), align] where `label` fits; `force`: the first anyway. */
  place(label, px, candidates, force) {
    ctx.font = `600 ${px}px system-ui, sans-serif`;
    const w = ctx.measureText(label).width + 2 * this.dpr;
    const box = ([x, y, align]) => {
      const x0 = align === 'right' ? x - w : align === 'center' ? x - w / 2 : x;
      return [x0, y - px, x0 + w, y + 0.25 * px];
    };
    const at = candidates.find((c) => this.free(box(c))) || (force ? candidates[0] : null);
    if (!at) return null;
    const b = box(at);
    this.taken.push(b);
    this.shown.push({ text: label, x0: b[0], y0: b[1], x1: b[2], y1: b[3] });
    return at;
  }
}

function drawStroke(X, Y, dpr) {
  if (!stroke || stroke.length < 2) return;
  ctx.beginPath();
  stroke.forEach((p, i) => (i ? ctx.lineTo(X(p.x), Y(p.y)) : ctx.moveTo(X(p.x), Y(p.y))));
  ctx.strokeStyle = '#f2b705';
  ctx.lineWidth = 3 * dpr;
  ctx.stroke();
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
  // The flag's stand, where a returned flag goes.
  const [fx, fy] = site.flag;
  ctx.beginPath();
  ctx.arc(X(fx), Y(fy), Math.max(5 * dpr, 10 * k), 0, 2 * Math.PI);
  ctx.setLineDash([3 * dpr, 3 * dpr]);
  ctx.stroke();
  ctx.setLineDash([]);
}

/** Each base's name, placed below its square or else above it, for drawing over the robots. */
function siteBoxes(labels, X, Y, k, dpr) {
  if (!map) return [];
  const out = [];
  for (const site of map.sites) {
    const half = Math.max(map.cell * 1.5, 20) * k;
    const [bx, by] = site.base;
    const label = `${site.team} base`;
    const at = labels.place(label, 11 * dpr, [
      [X(bx), Y(by) + half + 12 * dpr, 'center'], [X(bx), Y(by) - half - 4 * dpr, 'center'],
    ], true);
    out.push({ text: label, x: at[0], y: at[1], fill: colour(site.team), px: 11 * dpr });
  }
  return out;
}

function siteLabels(labels, X, Y, k, dpr) {
  for (const l of siteBoxes(labels, X, Y, k, dpr)) text(l.text, l.x, l.y, l.fill, l.px, 'center', true);
  api.labels = labels.shown;
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
  if (suppressClick) { suppressClick = false; return; }
  const at = clientToWorld(e.clientX, e.clientY);
  const h = hit(at);
  if (h && h.robot && h.robot.team === team && (e.ctrlKey || e.metaKey)) {
    pick(h.robot.id === picked ? null : h.robot.id);
    return;
  }
  if (h && h.robot && h.robot.team === team && picked === null && (selected === null || h.robot.squad === selected)) {
    select(h.robot.squad === selected ? null : h.robot.squad);
    return;
  }
  if (selected === null && picked === null) {
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
canvas.addEventListener('pointermove', (e) => {
  const h = hit(clientToWorld(e.clientX, e.clientY));
  const id = h && h.robot ? h.robot.id : null;
  if (id !== hover) { hover = id; dirty = true; }
});
canvas.addEventListener('pointerleave', () => { if (hover !== null) { hover = null; dirty = true; } });

// ---- drawing a path: press, drag, release -----------------------------------------------------
const DRAW_START_PX = 8; // a press that moves less is a click
const DRAW_STEP_PX = 6; // a point every so many pixels of the stroke
const MAX_DRAWN = 64; // the game's limit on a drawn path's points

canvas.addEventListener('pointerdown', (e) => {
  if (e.button !== 0) return;
  press = { x: e.clientX, y: e.clientY, last: { x: e.clientX, y: e.clientY } };
  stroke = null;
});

canvas.addEventListener('pointermove', (e) => {
  if (!press || !(e.buttons & 1)) return;
  if (!stroke) {
    if (Math.hypot(e.clientX - press.x, e.clientY - press.y) < DRAW_START_PX) return;
    stroke = [clientToWorld(press.x, press.y)];
    canvas.setPointerCapture(e.pointerId);
  }
  if (Math.hypot(e.clientX - press.last.x, e.clientY - press.last.y) >= DRAW_STEP_PX) {
    stroke.push(clientToWorld(e.clientX, e.clientY));
    press.last = { x: e.clientX, y: e.clientY };
    dirty = true;
  }
});

canvas.addEventListener('pointercancel', () => { press = null; stroke = null; dirty = true; });

canvas.addEventListener('pointerup', (e) => {
  const drawn = stroke;
  press = null;
  stroke = null;
  if (!drawn) return;
  suppressClick = true;
  dirty = true;
  drawn.push(clientToWorld(e.clientX, e.clientY));
  if (selected === null) {
    message(picked !== null ? 'a path is drawn for a squad: select a squad, not one robot' : 'select the squad to draw a path for first', false);
    return;
  }
  // Thinned to the game's limit, the first and the last point kept.
  const step = Math.ceil(drawn.length / MAX_DRAWN);
  const points = drawn.filter((_, i) => i % step === 0);
  if (points[points.length - 1] !== drawn[drawn.length - 1]) points.push(drawn[drawn.length - 1]);
  while (points.length > MAX_DRAWN) points.splice(points.length - 2, 1);
  order({ do: 'path', points: points.map((p) => [tenth(p.x), tenth(p.y)]) });
});

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
