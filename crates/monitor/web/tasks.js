// colony task board: MURDOCH's auctions as the monitor hears them. Plain
// JavaScript, no library. The server sends {"t":"tasks",...} (see the
// monitor's tasks.rs for the fields) at most ten times a second; the page
// redraws from each one. Everything shown comes from the network: it is
// escaped with esc().

import { $, esc, serverLink, showBanners, showChip, withToken } from './common.js';

$('monitor-link').href = withToken('/');

/** Milliseconds as the board shows an age: "4.2 s". */
const secs = (ms) => `${(ms / 1000).toFixed(1)} s`;

function bar(fraction, low) {
  const pct = Math.round(Math.max(0, Math.min(1, fraction)) * 100);
  return `<span class="bar${low ? ' low' : ''}" title="${pct} %"><span style="width:${pct}%"></span></span> ${pct} %`;
}

function robotRow(r) {
  const task = r.task == null ? '–' : `${esc(r.task_name ?? '')} #${esc(r.task)}`;
  const mode = r.silent ? `<span class="silent">silent</span> (was ${esc(r.mode)})` : esc(r.mode);
  return `<tr data-robot="${esc(r.name)}" data-mode="${esc(r.silent ? 'silent' : r.mode)}">`
    + `<td>${esc(r.name)}</td><td>${mode}</td><td>${bar(r.battery, r.battery < 0.2)}</td>`
    + `<td>${esc(r.resources.join(' ')) || '–'}</td><td>${task}</td></tr>`;
}

function bidRows(t) {
  if (t.bids.length === 0) return '<p class="muted">no bid heard</p>';
  const winner = t.winner?.bidder;
  const rows = t.bids.map((b) => {
    const cls = b.withdrawn ? 'withdrawn' : (b.round === t.round && b.bidder === winner ? 'won' : '');
    return `<tr class="bid ${cls}" data-bidder="${esc(b.bidder)}"><td>${esc(b.round)}</td>`
      + `<td>${esc(b.bidder)}</td><td>${esc(b.score.toFixed(1))}</td>`
      + `<td>${b.withdrawn ? 'withdrawn' : ''}</td></tr>`;
  }).join('');
  return `<table><thead><tr><th>round</th><th>bidder</th><th>score (cost)</th><th></th></tr></thead>`
    + `<tbody>${rows}</tbody></table>`;
}

function taskCard(t, now) {
  const name = t.name ? esc(t.name) : '<span class="muted">(announcement not heard)</span>';
  const retries = t.retries > 0
    ? `<span class="retries" data-retries="${esc(t.retries)}" title="announced again after failing">tried ×${esc(t.retries + 1)}</span>` : '';
  const realloc = t.reallocations > 0
    ? `<span class="realloc" data-reallocations="${esc(t.reallocations)}">re-allocated ×${esc(t.reallocations)}</span>` : '';
  const why = t.winner
    ? `<p class="why">winner <b class="winner">${esc(t.winner.bidder)}</b>: score ${esc(t.winner.score.toFixed(1))},
       the ${t.winner.bids === 1 ? 'only bid' : `lowest of ${esc(t.winner.bids)} bids`} the announcer heard`
      + (t.bids_missed > 0 ? ` (${esc(t.bids_missed)} not heard here)` : '') + '</p>'
    : '';
  const progress = t.progress == null ? '' : `<p>progress ${bar(t.progress, false)} · ${esc(t.renewals)} renewals</p>`;
  const reason = t.reason ? `<p class="why">last reason: ${esc(t.reason)}</p>` : '';
  const timeline = t.timeline.map((m) => `<li>+${secs(m.at - t.first)} ${esc(m.text)}</li>`).join('');
  return `<div class="task" data-task="${esc(t.announcer)}/${esc(t.id)}" data-state="${esc(t.state)}">`
    + `<h3>${name} <span class="muted">#${esc(t.id)} from ${esc(t.announcer)}</span>`
    + `<span class="state ${esc(t.state)}">${esc(t.state)}</span>${retries}${realloc}`
    + `<span class="muted">needs ${esc(t.resources.join(' ') || '?')} · ${esc(t.length_s)} s · round ${esc(t.round)} · ${secs(now - t.first)} ago</span></h3>`
    + why + progress + reason + bidRows(t)
    + `<details><summary>timeline (${t.timeline.length})</summary><ol class="timeline">${timeline}</ol></details></div>`;
}

/** Which timelines the operator opened, so a redraw keeps them open. */
const open = new Set();
let lastBoard = null;

// Retries are folded by the server (`retry_of`): a task announced again and again after
// failing is one card with a count, so the board shows the tasks that differ.
function shown(t) {
  if (t.retry_of != null && !$('show-retries').checked) return false;
  if (t.state === 'unachievable' && !$('show-unachievable').checked) return false;
  if (t.state === 'done' && !$('show-finished').checked) return false;
  return true;
}

// The operator's choice outlives a reload.
for (const id of ['show-unachievable', 'show-finished', 'show-retries']) {
  const saved = localStorage.getItem(`colony-tasks-${id}`);
  if (saved !== null) $(id).checked = saved === 'on';
  $(id).addEventListener('change', () => {
    localStorage.setItem(`colony-tasks-${id}`, $(id).checked ? 'on' : 'off');
    if (lastBoard) draw(lastBoard);
  });
}

function draw(board) {
  lastBoard = board;
  for (const d of document.querySelectorAll('.task details[open]')) {
    open.add(d.closest('.task').dataset.task);
  }
  const counts = {};
  for (const t of board.tasks) counts[t.state] = (counts[t.state] ?? 0) + 1;
  const text = Object.entries(counts).map(([s, n]) => `${n} ${s}`).join(' · ');
  $('counts').textContent = text || 'no tasks yet';
  if (board.robots.length > 0) $('robots').innerHTML = board.robots.map(robotRow).join('');
  if (board.tasks.length > 0) {
    const cards = board.tasks.filter(shown);
    const hidden = board.tasks.length - cards.length;
    $('hidden-note').textContent = hidden > 0 ? `${hidden} of ${board.tasks.length} hidden` : '';
    $('tasks').innerHTML = cards.map((t) => taskCard(t, board.now)).join('')
      || '<p class="muted">every task is hidden by the filters above</p>';
    for (const el of document.querySelectorAll('.task')) {
      if (open.has(el.dataset.task)) el.querySelector('details').open = true;
    }
  }
  const notes = [];
  if (board.forgotten > 0) notes.push({ cls: 'stale-banner', text: `${board.forgotten} older tasks are not shown` });
  if (board.robots_forgotten > 0) notes.push({ cls: 'stale-banner', text: `${board.robots_forgotten} robots silent longest are no longer shown` });
  if (board.bad > 0) notes.push({ cls: 'stale-banner', text: `${board.bad} MURDOCH packets did not read and were ignored` });
  if (board.forged > 0) notes.push({ cls: 'stale-banner', text: `${board.forged} MURDOCH messages were not sealed by whom they speak for and were left off` });
  showBanners($('banners'), notes);
}

serverLink(withToken('/ws?view=tasks'), {
  onOpen: () => showChip($('conn'), 'connected', true),
  onClose: () => showChip($('conn'), 'reconnecting…', false),
  onMessage: (msg) => { if (msg.t === 'tasks') draw(msg); },
});
