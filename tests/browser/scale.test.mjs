// The monitor with a big swarm: 256 robots and 2,560 pucks (the standard
// configuration scaled, arena 187 * sqrt(64) = 1,496 cm wide). The page
// draws every robot and puck, keeps applying snapshots as the world steps,
// and shows the newest one. How fast it does so (frames, world steps and
// snapshots a second, the slowest redraw) is a benchmark, not a test:
// scripts/bench-monitor (tests/browser/bench/monitor-scale.mjs), figures in
// BENCHMARKS.md. Every wait here is for an event, with room for a loaded
// machine.
import assert from 'node:assert/strict';
import { after, before, describe, test } from 'node:test';
import {
  ColonyProcess, launchBrowser, screenshot, startHub, startMonitor, until,
} from './lib.mjs';

const ROBOTS = 256;
const SPEED = 2.8; // about 13 world steps a second (the control period is 3/14 s)

describe('the monitor with 256 robots', { concurrency: false }, () => {
  let hub;
  let sim;
  let monitor;
  let browser;
  let page;

  before(async () => {
    hub = await startHub();
    // Controllers as threads: 256 robot processes would load the machine, not the monitor.
    sim = new ColonyProcess('sort-live-256', [
      'sort', 'live', '--hub', hub.addr, '--scale-robots', String(ROBOTS),
      '--speed', String(SPEED), '--controllers', 'thread',
    ]);
    await sim.waitFor(/live cachecons with 256 robots/, 120000);
    monitor = await startMonitor(hub.addr, 'monitor-256');
    browser = await launchBrowser({ width: 1400, height: 900 });
    page = browser.page;
    await page.goto(monitor.url);
  });

  after(async () => {
    if (browser) await browser.close();
    for (const p of [monitor, sim, hub]) if (p) await p.stop();
  });

  test('the page draws all 256 robots and 2,560 pucks and keeps showing the newest world step', async () => {
    await until(page, (n) => {
      const c = window.colony;
      return c.drawn.robots === n && c.drawn.pucks === 10 * n && !c.visionStale && !c.hubStale;
    }, ROBOTS, 120000, `no ${ROBOTS} robots and ${10 * ROBOTS} pucks drawn`);

    // Snapshots keep being applied: the step moves on, again and again, and
    // each time the canvas and the header catch up with the newest one.
    let last = await page.evaluate(() => ({ step: window.colony.step, worlds: window.colony.worlds }));
    for (let i = 0; i < 5; i++) {
      const now = await until(page, (prev) => {
        const c = window.colony;
        return c.step > prev.step && c.worlds > prev.worlds && { step: c.step, worlds: c.worlds };
      }, last, 60000, `the world did not move on from step ${last.step} on the page`);
      await until(page, (step) => {
        const c = window.colony;
        return c.drawn.step >= step && document.querySelector('#step').textContent === String(c.step);
      }, now.step, 60000, `the canvas and the header did not show step ${now.step} or later`);
      last = now;
    }
    const shown = await page.evaluate(() => ({
      drawn: window.colony.drawn,
      robots: Number(document.querySelector('#nrobots').textContent),
      pucks: Number(document.querySelector('#npucks').textContent),
      banners: document.querySelector('#banners').children.length,
      stale: window.colony.hubStale || window.colony.visionStale,
    }));
    assert.equal(shown.drawn.robots, ROBOTS, 'every robot drawn');
    assert.equal(shown.drawn.pucks, 10 * ROBOTS, 'every puck drawn');
    assert.equal(shown.robots, ROBOTS, 'the header counts every robot');
    assert.equal(shown.pucks, 10 * ROBOTS, 'the header counts every puck');
    assert.equal(shown.banners, 0, 'no stale banner');
    assert.equal(shown.stale, false, 'the page is live');
    assert.deepEqual(browser.errors, [], 'no script errors');
    await screenshot(page, 'e-256-robots');
  });
});
