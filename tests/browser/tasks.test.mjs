// The task board (/tasks) over a real hub with MURDOCH deployed as the paper
// does it: each robot's agent its own `colony tasks agent` process, tasks
// introduced with `colony tasks announce`. The page shows a task go from
// announced to done with its bid and winner; then the winner of a longer
// task is killed (SIGKILL) mid-task, and the page shows the task auctioned
// again and taken by the other robot. Last, the first hub's traffic log is
// replayed into a fresh hub, and a fresh monitor's board shows the same story.
// And box pushing run live: the monitor draws the robots, the box and the
// goal (which moves mid-run), and the board shows the watcher's push tasks.
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { after, before, describe, test } from 'node:test';
import {
  ColonyProcess, colony, launchBrowser, screenshot, startHub, startMonitor, until,
} from './lib.mjs';

/** The board's task cards as the page draws them. */
const cards = () => [...document.querySelectorAll('.task')].map((el) => ({
  name: el.querySelector('h3').textContent,
  key: el.dataset.task,
  state: el.dataset.state,
  bidders: [...el.querySelectorAll('tr.bid')].map((r) => r.dataset.bidder),
  winner: el.querySelector('.winner')?.textContent ?? null,
  reallocations: Number(el.querySelector('[data-reallocations]')?.dataset.reallocations ?? 0),
}));

describe('the task board', { concurrency: false }, () => {
  const procs = [];
  const agents = {};
  let hub;
  let log;
  let browser;
  let page;
  let monitorUrl;

  before(async () => {
    log = path.join(fs.mkdtempSync(path.join(os.tmpdir(), 'colony-tasks-log-')), 'tasks.clog');
    hub = await startHub(undefined, ['--log', log]);
    procs.push(hub);
    const monitor = await startMonitor(hub.addr, 'monitor-tasks');
    procs.push(monitor);
    monitorUrl = monitor.url;
    for (const name of ['ra', 'rb']) {
      const a = new ColonyProcess(`agent-${name}`, ['tasks', 'agent', '--hub', hub.addr, '--name', name, '--resources', 'camera,mobile']);
      await a.waitFor(/joins with/);
      agents[name] = a;
      procs.push(a);
    }
    browser = await launchBrowser();
    page = browser.page;
    await page.goto(monitor.url.replace('/?', '/tasks?'));
  });

  after(async () => {
    if (browser) await browser.close();
    for (const p of procs.reverse()) await p.stop();
  });

  test('shows both robots from their reports, idle with their resources', async () => {
    await until(page, () => ['ra', 'rb'].every((n) => document.querySelector(`tr[data-robot="${n}"][data-mode="idle"]`)),
      undefined, 30000, 'the robots never showed as idle');
    const text = await page.textContent('tr[data-robot="ra"]');
    assert.match(text, /camera mobile/);
  });

  test('the system monitor beside a task run shows no world panel and nothing stale', async () => {
    const other = await browser.context.newPage();
    try {
      await other.goto(monitorUrl);
      await until(other, () => window.colony && window.colony.hubs > 0 && window.colony.worlds > 0,
        undefined, 20000, 'the monitor page heard nothing');
      // Past the two seconds after which a silent vision would be called stale.
      await new Promise((r) => setTimeout(r, 3000));
      const seen = await other.evaluate(() => ({
        phase: window.colony.worldPhase,
        live: document.getElementById('live').hidden,
        plot: document.getElementById('plot-box').hidden,
        banners: document.getElementById('banners').textContent,
        chip: document.getElementById('conn').textContent,
      }));
      assert.equal(seen.phase, 'none');
      assert.ok(seen.live && seen.plot, 'the arena and the progress chart are hidden with no world');
      assert.ok(!/stale/i.test(seen.banners), `no stale warning: ${seen.banners}`);
      assert.equal(seen.chip, 'live');
    } finally {
      await other.close();
    }
  });

  test('a task announced from the command line goes from announced to done with its bids and winner', async () => {
    const out = await colony(['tasks', 'announce', '--hub', hub.addr, '--name', 'inspect', '--needs', 'camera', '--length', '1', '--as', 'ops'], 60000);
    assert.match(out, /done by r[ab]/);
    const done = await until(page, () => {
      const c = [...document.querySelectorAll('.task')].find((el) => el.dataset.state === 'done');
      return c && c.querySelectorAll('tr.bid').length > 0 && c.dataset.task;
    }, undefined, 30000, 'the task never showed as done with its bids');
    const card = (await page.evaluate(cards)).find((c) => c.key === done);
    assert.match(card.name, /inspect/);
    assert.ok(card.bidders.length >= 1, JSON.stringify(card));
    assert.ok(['ra', 'rb'].includes(card.winner), JSON.stringify(card));
    // The timeline says who won and why.
    await page.click(`.task[data-task="${done}"] summary`);
    const timeline = await page.textContent(`.task[data-task="${done}"] .timeline`);
    assert.match(timeline, /announced to \{camera\}/);
    assert.match(timeline, /awarded to r[ab]: .* is the (only bid|lowest of \d bids)/);
    assert.match(timeline, /finished it/);
    await screenshot(page, 't-task-done');
  });

  test('a task retried after failing is one card with a count, and the filters hide and show', async () => {
    for (let i = 0; i < 3; i++) {
      await assert.rejects(colony(['tasks', 'announce', '--hub', hub.addr, '--name', 'zap', '--needs', 'laser', '--deadline', '1'], 30000));
    }
    const zap = () => [...document.querySelectorAll('.task')].filter((el) => /zap/.test(el.querySelector('h3').textContent))
      .map((el) => ({ state: el.dataset.state, retries: el.querySelector('[data-retries]')?.dataset.retries ?? null }));
    await until(page, () => {
      const cards = [...document.querySelectorAll('.task')].filter((el) => /zap/.test(el.querySelector('h3').textContent));
      // Each announce may itself try more than once before its deadline; the page may
      // draw the newest try before its `unachievable` arrives.
      return cards.length === 1 && Number(cards[0].querySelector('[data-retries]')?.dataset.retries) >= 2
        && cards[0].dataset.state === 'unachievable';
    }, undefined, 30000, 'the three failures of zap are not one card tried three times').catch(async (e) => {
      throw new Error(`${e.message}: ${JSON.stringify(await page.evaluate(zap))}`);
    });
    const [one] = await page.evaluate(zap);
    assert.equal(one.state, 'unachievable');
    await page.check('#show-retries');
    assert.equal((await page.evaluate(zap)).length, Number(one.retries) + 1, 'every try on its own card when asked');
    await page.uncheck('#show-retries');
    await page.uncheck('#show-unachievable');
    assert.deepEqual(await page.evaluate(zap), [], 'unachievable tasks hidden');
    assert.match(await page.textContent('#hidden-note'), /hidden/);
    await page.uncheck('#show-finished');
    assert.ok(!(await page.$('.task[data-state="done"]')), 'finished tasks hidden');
    await page.check('#show-unachievable');
    await page.check('#show-finished');
    assert.ok(await page.$('.task[data-state="done"]'));
  });

  test('killing the winner mid-task shows the task re-allocated to the other robot', async () => {
    const announce = new ColonyProcess('announce-patrol', ['tasks', 'announce', '--hub', hub.addr, '--name', 'patrol', '--needs', 'mobile', '--length', '6', '--as', 'ops2']);
    procs.push(announce);
    const winner = await until(page, () => {
      const c = [...document.querySelectorAll('.task')].find((el) => /patrol/.test(el.querySelector('h3').textContent));
      return c && c.dataset.state === 'running' && c.querySelector('.winner')?.textContent;
    }, undefined, 30000, 'the patrol task never showed as running');
    await agents[winner].stop('SIGKILL');
    const other = winner === 'ra' ? 'rb' : 'ra';
    await until(page, (o) => {
      const c = [...document.querySelectorAll('.task')].find((el) => /patrol/.test(el.querySelector('h3').textContent));
      return c && c.querySelector('[data-reallocations]') && c.querySelector('.winner')?.textContent === o;
    }, other, 30000, 'the patrol task never showed re-allocated to the other robot');
    const card = (await page.evaluate(cards)).find((c) => /patrol/.test(c.name));
    assert.equal(card.reallocations, 1, JSON.stringify(card));
    await page.click(`.task[data-task="${card.key}"] summary`);
    assert.match(await page.textContent(`.task[data-task="${card.key}"] .timeline`), /withdrew it: presumed failed/);
    // The killed robot falls silent on the board.
    await until(page, (w) => document.querySelector(`tr[data-robot="${w}"][data-mode="silent"]`), winner, 30000,
      'the killed robot never showed as silent');
    await screenshot(page, 't-task-reallocated');
    const { code } = await announce.exited;
    assert.equal(code, 0, announce.text);
  });

  test('a replayed traffic log shows the same tasks on a fresh hub\'s board', async () => {
    const again = await startHub();
    procs.push(again);
    const monitor = await startMonitor(again.addr, 'monitor-replay');
    procs.push(monitor);
    const second = await browser.context.newPage();
    await second.goto(monitor.url.replace('/?', '/tasks?'));
    await until(second, () => document.querySelector('#conn.ok'), undefined, 30000, 'the replay page never connected');
    await colony(['replay', log, '--hub', again.addr, '--speed', '4'], 120000);
    await until(second, () => {
      const all = [...document.querySelectorAll('.task')];
      const inspect = all.find((el) => /inspect/.test(el.querySelector('h3').textContent));
      const patrol = all.find((el) => /patrol/.test(el.querySelector('h3').textContent));
      return inspect?.dataset.state === 'done' && patrol?.dataset.state === 'done'
        && patrol.querySelector('[data-reallocations="1"]');
    }, undefined, 30000, 'the replayed board never showed both tasks done, patrol re-allocated once');
    await screenshot(second, 't-task-replayed');
  });

  test('box pushing run live is drawn in the monitor and its push auctions are on the board', async () => {
    const monitorUrl = (await page.evaluate(() => location.href)).replace('/tasks?', '/?');
    const view = await browser.context.newPage();
    await view.goto(monitorUrl);
    const run = new ColonyProcess('boxpush-live', ['tasks', 'boxpush', '--hub', hub.addr, '--speed', '10', '--move-goal-at', '20', '--moved-goal', '520,430']);
    procs.push(run);
    const first = await until(view, () => window.colony.robots === 3 && window.colony.boxes.length === 1 && window.colony.goal,
      undefined, 30000, 'the monitor never drew the watcher, the pushers, the box and the goal');
    // The field's (360, 400) is drawn at (10, 100), and (520, 430) at (170, 130): the arena is
    // centred on the origin. (A slow start may miss the first.)
    assert.ok([[10, 100], [170, 130]].some((g) => g[0] === first[0] && g[1] === first[1]), JSON.stringify(first));
    await until(view, () => window.colony.goal[0] === 170 && window.colony.goal[1] === 130, undefined, 60000,
      'the goal never moved on the monitor');
    await until(page, () => [...document.querySelectorAll('.task h3')].some((h) => /push-(left|right)-end/.test(h.textContent)),
      undefined, 30000, 'the board never showed a push task');
    await until(page, () => document.querySelector('tr[data-robot="watcher"][data-mode="working"]'), undefined, 30000,
      'the board never showed the watcher at work');
    await screenshot(view, 't-boxpush-live');
    const { code } = await run.exited;
    assert.equal(code, 0, run.text);
    assert.match(run.text, /the goal moved to \(520, 430\)/);
    assert.match(run.text, /box at the goal/);
  });
});
