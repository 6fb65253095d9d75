// The monitor page at swarm scale: 2,000 robots and 20,000 pucks
// (`--scale-robots 2000`: the controllers run in the world's own step above
// 1,024 robots), each frame some 15 `vision` datagrams. Zoomed out, the page
// draws every body as pixels; zoomed in, as shapes; every frame it draws is
// whole, and the frames missing a part are shown (none are expected here, but
// the count is on the page). How fast is a benchmark, not a test:
// scripts/bench-monitor-swarm (tests/browser/bench/monitor-swarm.mjs).
import assert from 'node:assert/strict';
import { after, before, describe, test } from 'node:test';
import {
  ColonyProcess, launchBrowser, screenshot, startHub, startMonitor, until,
} from './lib.mjs';

const ROBOTS = 2000;

describe('the monitor with 2,000 robots', { concurrency: false }, () => {
  let hub;
  let sim;
  let monitor;
  let browser;
  let page;

  before(async () => {
    hub = await startHub();
    sim = new ColonyProcess('sort-live-2000', [
      'sort', 'live', '--hub', hub.addr, '--scale-robots', String(ROBOTS),
      '--speed', '3', '--controllers', 'thread',
    ]);
    await sim.waitFor(/live cachecons with 2000 robots/, 120000);
    monitor = await startMonitor(hub.addr, 'monitor-2000');
    browser = await launchBrowser({ width: 1200, height: 800 });
    page = browser.page;
    await page.goto(monitor.url);
  });

  after(async () => {
    if (browser) await browser.close();
    for (const p of [monitor, sim, hub]) if (p) await p.stop();
  });

  test('every robot and puck is drawn from whole frames, as pixels zoomed out and as shapes zoomed in', async () => {
    await until(page, (n) => {
      const c = window.colony;
      return c.drawn.robots === n && c.drawn.pucks === 10 * n && c.raster;
    }, ROBOTS, 120000, `no ${ROBOTS} robots and ${10 * ROBOTS} pucks drawn as pixels`);
    // The robots move: the world's frames keep coming, each drawn whole.
    const first = await page.evaluate(() => ({ step: window.colony.step, poses: window.colony.poses }));
    await until(page, (s) => window.colony.drawn.step > s, first.step, 60000, 'no newer frame drawn');
    const later = await page.evaluate(() => window.colony.poses);
    assert.equal(Object.keys(later).length, ROBOTS);
    const moved = Object.keys(later).filter((id) => {
      const [a, b] = [first.poses[id], later[id]];
      return Math.hypot(a[0] - b[0], a[1] - b[1]) > 0.01 || Math.abs(a[2] - b[2]) > 0.001;
    });
    assert.ok(moved.length > ROBOTS / 10, `robots moved between frames: ${moved.length}`);
    const shown = await page.evaluate(() => ({
      missing: document.querySelector('#missing').textContent,
      whole: window.colony.framesWhole,
      robots: Number(document.querySelector('#nrobots').textContent),
      pucks: Number(document.querySelector('#npucks').textContent),
    }));
    assert.equal(shown.missing, String(await page.evaluate(() => window.colony.framesMissing)), 'frames missing shown');
    assert.ok(shown.whole > 0);
    assert.deepEqual([shown.robots, shown.pucks], [ROBOTS, 10 * ROBOTS]);
    await screenshot(page, 'f-2000-robots');

    // Zoomed in on the middle: shapes, only those in view.
    const box = await page.locator('#arena').boundingBox();
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    for (let i = 0; i < 4; i++) await page.mouse.wheel(0, -400);
    const draws = await page.evaluate(() => window.colony.draws);
    await until(page, (d) => !window.colony.raster && window.colony.draws > d, draws, 30000, 'no redraw as shapes');
    const inView = await page.evaluate(() => window.colony.shapes);
    assert.ok(inView.robots > 0 && inView.robots < ROBOTS, `some robots in view, not all: ${JSON.stringify(inView)}`);
    assert.ok(inView.pucks > 0 && inView.pucks < 10 * ROBOTS, `some pucks in view, not all: ${JSON.stringify(inView)}`);
    await screenshot(page, 'f-2000-robots-zoomed');
    assert.deepEqual(browser.errors, [], 'no script errors');
  });
});
