// The monitor keeps up with a big swarm: 256 robots and 2,560 pucks (the
// standard configuration scaled, arena 187 * sqrt(64) = 1,496 cm wide) at
// about 13 world steps a second (the control period is 3/14 s, so speed
// 13 * 3/14 = 2.8), while the page keeps drawing at 30 frames a second or
// more. The figure is printed as a `# MONITOR_FPS` line for BENCHMARKS.md.
import assert from 'node:assert/strict';
import os from 'node:os';
import { after, before, describe, test } from 'node:test';
import {
  ColonyProcess, launchBrowser, screenshot, sleep, startHub, startMonitor, until,
} from './lib.mjs';

const ROBOTS = 256;
const SPEED = 2.8;
const WINDOW_MS = 10000;

describe('the monitor with 256 robots', { concurrency: false }, () => {
  let hub;
  let sim;
  let monitor;
  let browser;
  let page;

  before(async () => {
    hub = await startHub();
    // Controllers as threads: 256 robot processes would measure the machine, not the monitor.
    sim = new ColonyProcess('sort-live-256', [
      'sort', 'live', '--hub', hub.addr, '--scale-robots', String(ROBOTS),
      '--speed', String(SPEED), '--controllers', 'thread',
    ]);
    await sim.waitFor(/live cachecons with 256 robots/, 60000);
    monitor = await startMonitor(hub.addr, 'monitor-256');
    browser = await launchBrowser({ width: 1400, height: 900 });
    page = browser.page;
    await page.goto(monitor.url);
  });

  after(async () => {
    if (browser) await browser.close();
    for (const p of [monitor, sim, hub]) if (p) await p.stop();
  });

  test('the page draws 256 robots at 30 frames a second or more while the world makes ~13 steps a second', async () => {
    await until(page, (n) => window.colony.robots === n && window.colony.pucks === 10 * n && !window.colony.visionStale,
      ROBOTS, 60000, `no ${ROBOTS} robots on the page`);
    await sleep(2000); // let the page settle
    const sample = () => page.evaluate(() => ({
      t: performance.now(), frames: window.colony.frames, step: window.colony.step,
      worlds: window.colony.worlds, drawMs: window.colony.drawMs,
    }));
    const a = await sample();
    let maxDraw = 0;
    const until0 = Date.now() + WINDOW_MS;
    while (Date.now() < until0) {
      await sleep(500);
      maxDraw = Math.max(maxDraw, (await sample()).drawMs);
    }
    const b = await sample();
    const secs = (b.t - a.t) / 1000;
    const fps = (b.frames - a.frames) / secs;
    const steps = (b.step - a.step) / secs;
    const worlds = (b.worlds - a.worlds) / secs;
    const figure = {
      robots: ROBOTS, pucks: 10 * ROBOTS, speed: SPEED, window_s: Number(secs.toFixed(1)),
      fps: Number(fps.toFixed(1)), world_steps_per_s: Number(steps.toFixed(1)),
      snapshots_per_s: Number(worlds.toFixed(1)), max_draw_ms: Number(maxDraw.toFixed(1)),
      cpus: os.cpus().length, cpu: os.cpus()[0]?.model,
    };
    console.log(`# MONITOR_FPS ${JSON.stringify(figure)}`);
    await screenshot(page, 'e-256-robots');
    assert.deepEqual(browser.errors, [], 'no script errors');
    assert.ok(fps >= 30, `the page drew ${fps.toFixed(1)} frames a second (at least 30 wanted)`);
    assert.ok(steps >= 8, `the world made ${steps.toFixed(1)} steps a second (about 13 wanted; a slower machine cannot keep up)`);
    assert.ok(worlds >= 0.8 * Math.min(steps, 30),
      `the page got ${worlds.toFixed(1)} snapshots a second for ${steps.toFixed(1)} world steps: it keeps up`);
  });
});
