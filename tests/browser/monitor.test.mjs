// The monitor in a real browser against a real hub and a real simulator:
// `colony hub`, `colony sort live --speed 5` (CACHECONS, 4 robots, 40 pucks,
// each robot's controller its own process) and `colony monitor`, with the
// page in Debian's headless Chromium. Tests run in order: the last one kills
// the hub. Screenshots go to test-artifacts/browser/. Every wait is for an
// event, with room for a loaded machine; how soon things happen (the stale
// banner's delay) is measured by scripts/bench-monitor, not asserted here.
import assert from 'node:assert/strict';
import http from 'node:http';
import { after, before, describe, test } from 'node:test';
import {
  ColonyProcess, colony, launchBrowser, screenshot, sleep, startHub, startMonitor, until,
} from './lib.mjs';

describe('the monitor page, against a live swarm', { concurrency: false }, () => {
  let hub;
  let sim;
  let monitor;
  let browser;
  let page;

  before(async () => {
    hub = await startHub();
    sim = new ColonyProcess('sort-live', ['sort', 'live', '--hub', hub.addr, '--speed', '5']);
    await sim.waitFor(/live cachecons with 4 robots/);
    monitor = await startMonitor(hub.addr);
    browser = await launchBrowser();
    page = browser.page;
    await page.goto(monitor.url);
  });

  after(async () => {
    if (browser) await browser.close();
    for (const p of [monitor, sim, hub]) if (p) await p.stop();
  });

  const poses = () => page.evaluate(() => window.colony.poses);

  // Waits until the page shows a later world step than it does now.
  async function worldAdvances(what) {
    const step0 = await page.evaluate(() => window.colony.step);
    await until(page, (s0) => window.colony.step > s0, step0, 30000, `${what} (step ${step0})`);
  }

  // Waits until at least `n` robots are `cm` or more from where `from` had them.
  const robotsMove = (from, n, cm, what) => until(page, ([p0, k, d]) => {
    const p = window.colony.poses;
    const moved = Object.keys(p0).map((id) => Math.hypot(p[id][0] - p0[id][0], p[id][1] - p0[id][1]));
    return moved.filter((m) => m > d).length >= k && moved;
  }, [from, n, cm], 30000, what);

  test('the page shows the 4 robots and 40 pucks of the standard configuration', async () => {
    await until(page, () => window.colony.robots === 4 && window.colony.pucks === 40 && !window.colony.visionStale,
      undefined, 60000, 'no 4 robots and 40 pucks');
    await worldAdvances('the world does not advance on the page');
    // Intentions from <debug> and the PC plot from <metrics> arrive too.
    await until(page, () => Object.keys(window.colony.states).length === 4 && window.colony.pc !== null,
      undefined, 30000, 'no FSM states for the 4 robots, or no PC');
    assert.equal(await page.locator('#nrobots').textContent(), '4');
    assert.equal(await page.locator('#npucks').textContent(), '40');
    assert.deepEqual(browser.errors, [], 'no script errors');
    await screenshot(page, 'a-robots-and-pucks');
  });

  test('a packet published with colony pub appears in the hub view', async () => {
    // The monitor learns of a new channel from the hub's status report and
    // subscribes to it; publish until the packet itself is shown.
    const deadline = Date.now() + 60000;
    let seen = false;
    for (let n = 1; Date.now() < deadline && !seen; n++) {
      await colony(['pub', '--hub', hub.addr, 'test.browser', `hello from "colony pub" n ${n}`]);
      seen = await page.evaluate(() => {
        const c = window.colony.channels['test.browser'];
        return !!(c && c.last && c.last.includes('hello from'));
      });
      if (!seen) await sleep(500);
    }
    assert.ok(seen, 'the hub view shows the packet published on <test.browser>');
    await until(page, () => document.querySelector('#channels').textContent.includes('hello from "colony pub"'),
      undefined, 15000, 'the channel table does not show the packet');

    // The forge box: a bad packet is refused with its line and column, a good one is published.
    await page.fill('#forge', '@ <test.forged> 0\nhello x (y 1');
    await page.click('#publish');
    await until(page, () => /line 2, column \d+/.test(document.querySelector('#forge-msg').textContent),
      undefined, 15000, 'no line and column for a malformed forged packet');
    await page.fill('#forge', '@ <test.forged> 0\nhello from "the page"');
    await page.click('#publish');
    await until(page, () => {
      const c = window.colony.channels['test.forged'];
      return c && c.last && c.last.includes('the page');
    }, undefined, 30000, 'the forged packet does not appear in the hub view');
    await screenshot(page, 'b-hub-view');
  });

  test('an operator takes robot 0 to a clicked point while the others keep sorting, then hands it back', async () => {
    await page.fill('#sel-ids', '0');
    await page.press('#sel-ids', 'Enter');
    await page.click('#take');
    await until(page, () => window.colony.held.includes(0), undefined, 15000, 'robot 0 is not held');

    // A target on the floor 35 cm or more from robot 0, with no robot near it.
    const p = await poses();
    const candidates = [[0, 0], [45, 45], [-45, 45], [45, -45], [-45, -45], [0, 55], [0, -55], [55, 0], [-55, 0]];
    const clear = ([x, y]) => Object.values(p).every(([rx, ry]) => Math.hypot(rx - x, ry - y) > 20);
    const target = candidates.find((c) => clear(c) && Math.hypot(p[0][0] - c[0], p[0][1] - c[1]) > 35)
      ?? candidates.find(clear);
    assert.ok(target, `a clear target among ${JSON.stringify(candidates)} (robots at ${JSON.stringify(p)})`);
    const startDist = Math.hypot(p[0][0] - target[0], p[0][1] - target[1]);
    const others0 = { 1: p[1], 2: p[2], 3: p[3] };
    const states = new Set();
    const watchStates = setInterval(async () => {
      const s = await page.evaluate(() => window.colony.states[1]).catch(() => null);
      if (s) states.add(s);
    }, 200);

    const at = await page.evaluate(([x, y]) => window.colony.worldToClient(x, y), target);
    await page.mouse.click(at.x, at.y);
    await until(page, (t) => window.colony.lastReply && window.colony.lastReply.to === 'goto' && window.colony.lastReply.ok,
      target, 15000, 'the goto was not accepted');
    await screenshot(page, 'c1-robot-0-held');
    const dist = await until(page, ([x, y]) => {
      const r = window.colony.poses[0];
      const d = r && Math.hypot(r[0] - x, r[1] - y);
      return d < 8 ? d : false;
    }, target, 90000, `robot 0 did not reach (${target}) from ${startDist.toFixed(1)} cm away`);
    clearInterval(watchStates);

    // The simulator itself (not just the page) has robot 0 there: ask the hub.
    const vision = await colony(['sub', '--hub', hub.addr, '-n', '1', 'vision']);
    const m = vision.match(/robot id 0 x (\S+) y (\S+)/);
    assert.ok(m, `robot 0 in a vision packet:\n${vision}`);
    assert.ok(Math.hypot(Number(m[1]) - target[0], Number(m[2]) - target[1]) < 10,
      `the simulator has robot 0 at (${m[1]}, ${m[2]}), near the target (${target})`);

    // Meanwhile the others kept sorting.
    const p2 = await poses();
    const moved = [1, 2, 3].map((id) => Math.hypot(p2[id][0] - others0[id][0], p2[id][1] - others0[id][1]));
    assert.ok(moved.every((d) => d > 2), `robots 1-3 moved on their own: ${moved.map((d) => d.toFixed(1))} cm`);
    assert.ok(states.size >= 1, 'robot 1 reported its FSM state throughout');
    console.log(`# robot 0: ${startDist.toFixed(1)} cm -> ${dist.toFixed(1)} cm from (${target}); robots 1-3 moved ${moved.map((d) => d.toFixed(0)).join(', ')} cm; robot 1 states seen: ${[...states].join(', ')}`);
    await screenshot(page, 'c2-robot-0-at-target');

    // Hold still: it stays while held. The others keep sorting around it and may shove it
    // (a robot homing with a puck does not steer around a held one), so what is asserted is
    // that the held robot keeps to its target: where pushed off, it drives back.
    await sleep(1500);
    const held = (await poses())[0];
    const drift = Math.hypot(held[0] - target[0], held[1] - target[1]);
    if (drift >= 10) {
      console.log(`# robot 0 was ${drift.toFixed(1)} cm from its target 1.5 s after reaching it; waiting for it to return`);
      await until(page, ([x, y]) => {
        const r = window.colony.poses[0];
        return window.colony.held.includes(0) && r && Math.hypot(r[0] - x, r[1] - y) < 10;
      }, target, 60000, 'a held robot pushed off its target drives back to it');
    }

    // The keyboard: in open floor, holding the left arrow turns robot 0 on the spot.
    await page.focus('#arena');
    let turned = 0;
    let last = (await poses())[0][2];
    await page.keyboard.down('ArrowLeft');
    const keysDown = Date.now();
    while (turned <= 0.5 && Date.now() - keysDown < 30000) {
      await sleep(40);
      const th = (await poses())[0][2];
      let d = th - last;
      while (d > Math.PI) d -= 2 * Math.PI;
      while (d < -Math.PI) d += 2 * Math.PI;
      turned += d;
      last = th;
    }
    await page.keyboard.up('ArrowLeft');
    assert.ok(turned > 0.5, `the left arrow turned robot 0 counter-clockwise (${turned.toFixed(2)} rad)`);
    await sleep(700); // the key's command lapses: held still again
    const rest = (await poses())[0];

    await page.click('#release');
    await until(page, () => window.colony.held.length === 0, undefined, 15000, 'robot 0 was not released');
    const statesAfter = new Set();
    const t0 = Date.now();
    let away = 0;
    while (Date.now() - t0 < 30000) {
      const [now, s] = await page.evaluate(() => [window.colony.poses[0], window.colony.states[0]]);
      if (s) statesAfter.add(s);
      away = Math.hypot(now[0] - rest[0], now[1] - rest[1]);
      if (away > 6) break;
      await sleep(200);
    }
    assert.ok(away > 6, `released, robot 0 moves on its own (moved ${away.toFixed(1)} cm)`);
    assert.ok(statesAfter.size >= 1, 'robot 0 reports its FSM state again');
    await screenshot(page, 'c3-robot-0-released');
  });

  test('taking control of all raises the hub minimum priority, stops every robot, and release restores both', async () => {
    await page.click('#take-all');
    await until(page, () => window.colony.held.length === 4 && window.colony.all && window.colony.minPriority === 10,
      undefined, 30000, 'not all 4 robots held with the minimum priority at 10');
    // The world still shows (vision outranks the override), and every robot is held still.
    await sleep(1500);
    const a = await poses();
    await sleep(1500);
    const b = await poses();
    const moved = [0, 1, 2, 3].map((id) => Math.hypot(b[id][0] - a[id][0], b[id][1] - a[id][1]));
    assert.ok(moved.every((d) => d < 1), `all held robots stand still: ${moved.map((d) => d.toFixed(2))} cm`);
    assert.ok(!(await page.evaluate(() => window.colony.visionStale)), 'the page still sees the world');
    const status = await colony(['status', '--hub', hub.addr]);
    assert.match(status, /minimum priority 10/);
    await screenshot(page, 'c4-all-held');
    await page.click('#release-all');
    await until(page, () => window.colony.held.length === 0 && window.colony.minPriority === null,
      undefined, 30000, 'the minimum priority was not restored');
    const after = await robotsMove(await poses(), 2, 2, 'released, two or more robots do not move again');
    console.log(`# released, the robots moved ${after.map((m) => m.toFixed(1)).join(', ')} cm`);
  });

  test('closing the tab that took control of all hands every robot back and restores the minimum priority', async () => {
    const tab = await browser.context.newPage();
    await tab.goto(monitor.url);
    await until(tab, () => window.colony.connected && window.colony.robots === 4, undefined, 30000, 'the second tab is not connected');
    await tab.click('#take-all');
    await until(page, () => window.colony.held.length === 4 && window.colony.all && window.colony.minPriority === 10,
      undefined, 30000, 'the other tab did not take all 4 robots with the minimum priority at 10');
    // The operator closes that tab without pressing release: this page still watches.
    await tab.close();
    await until(page, () => window.colony.held.length === 0 && !window.colony.all && window.colony.minPriority === null,
      undefined, 30000, 'closing the tab that held the robots did not hand them back');
    const status = await colony(['status', '--hub', hub.addr]);
    assert.doesNotMatch(status, /minimum priority 10/);
    const after = await robotsMove(await poses(), 2, 2, 'handed back, two or more robots do not move again');
    console.log(`# tab closed: the robots moved ${after.map((m) => m.toFixed(1)).join(', ')} cm`);
  });

  test('a page of another site cannot open the monitor\'s WebSocket, even knowing its token', async () => {
    const evil = http.createServer((req, res) => {
      res.writeHead(200, { 'content-type': 'text/html' });
      res.end('<!doctype html><title>another site</title><p>nothing to see');
    });
    await new Promise((resolve) => evil.listen(0, '127.0.0.1', resolve));
    const tab = await browser.context.newPage();
    try {
      await tab.goto(`http://127.0.0.1:${evil.address().port}/`);
      const wsUrl = monitor.url.replace('http://', 'ws://').replace('/?', '/ws?');
      const outcome = await tab.evaluate((url) => new Promise((resolve) => {
        const ws = new WebSocket(url);
        ws.onopen = () => { ws.send('{"t":"take_all"}'); resolve('opened'); };
        ws.onerror = () => resolve('refused');
      }), wsUrl);
      assert.equal(outcome, 'refused');
      await monitor.waitFor(/refused a web request.*origin/, 10000);
      assert.equal(await page.evaluate(() => window.colony.held.length), 0, 'nothing was taken');
      // The operator's page shows the refusal, within a hub report or two.
      await until(page, () => (window.colony.monitor?.refused ?? 0) >= 1
        && /web requests refused[^:]*: [1-9]/.test(document.querySelector('#monitor-counts').textContent),
      null, 10000, 'the refusal on the page');
    } finally {
      await tab.close();
      evil.close();
    }
  });

  test('killing the hub shows the stale state, and restarting it recovers the page', async () => {
    const port = hub.port;
    await until(page, () => !window.colony.hubStale && !window.colony.visionStale, undefined, 30000, 'the page is stale before the test');
    const killed = Date.now();
    await hub.stop('SIGKILL');
    await until(page, () => !!document.querySelector('#banner-hub') && window.colony.hubStale,
      undefined, 30000, 'no stale banner after the hub was killed');
    const shownAfter = Date.now() - killed;
    const banner = await page.locator('#banner-hub').textContent();
    assert.match(banner, /hub stale since \d\d:\d\d:\d\d/);
    console.log(`# stale banner ${shownAfter} ms after the hub was killed: "${banner}"`);
    await screenshot(page, 'd1-hub-killed-stale');

    hub = await startHub(port);
    const restarted = Date.now();
    await until(page, () => !window.colony.hubStale && !window.colony.visionStale
      && !document.querySelector('#banners').children.length
      && window.colony.robots === 4 && window.colony.pucks === 40,
      undefined, 60000, 'the page did not recover after the hub restarted');
    await worldAdvances('the world does not move on the page again');
    console.log(`# recovered ${Date.now() - restarted} ms after the hub restarted`);
    await screenshot(page, 'd2-hub-back');
  });
});
