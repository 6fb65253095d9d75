// The monitor page at swarm scale: 10,000 robots and 100,000 pucks
// (`--scale-robots 10000`, arena 93.5 m wide), the controllers in the world's
// own step (`--controllers thread` above 1,024 robots), the world as fast as it
// can step (`--speed 1000`), in Debian's headless Chromium. Measures, over a
// window after the whole swarm is on screen: the page's animation frames a
// second, its redraws a second, the distinct world frames it drew a second,
// the world's whole frames a second reaching the monitor, the frames the
// monitor dropped for a missing part, and the slowest redraw. A benchmark,
// not a test (its file name keeps `node --test` away): it asserts nothing.
// scripts/bench-monitor-swarm builds the release binary and runs it, every
// step bounded in time.
//
//   COLONY_BIN=target/release/colony node tests/browser/bench/monitor-swarm.mjs [--robots 10000] [--speed 1000] [--window 20] [--runs 1]
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';
import {
  ColonyProcess, ROOT, launchBrowser, screenshot, sleep, startHub, startMonitor, until,
} from '../lib.mjs';

const { values } = parseArgs({
  options: {
    robots: { type: 'string', default: '10000' },
    speed: { type: 'string', default: '1000' },
    window: { type: 'string', default: '20' },
    settle: { type: 'string', default: '3' },
    runs: { type: 'string', default: '1' },
  },
});
const robots = Number(values.robots);
const speed = Number(values.speed);
const windowMs = Number(values.window) * 1000;
const settleMs = Number(values.settle) * 1000;
const runs = Number(values.runs);
if (!(robots > 0) || !(speed > 0) || !(windowMs > 0) || !(settleMs >= 0) || !(runs >= 1)) {
  throw new Error('--robots, --speed, --window and --runs must be positive numbers, --settle zero or more');
}
if (!process.env.COLONY_BIN) process.env.COLONY_BIN = path.join(ROOT, 'target', 'release', 'colony');

const hub = await startHub();
const procs = [hub];
let browser;
try {
  const sim = new ColonyProcess('bench-sort-live-swarm', [
    'sort', 'live', '--hub', hub.addr, '--scale-robots', String(robots),
    '--speed', String(speed), '--controllers', 'thread',
  ]);
  procs.push(sim);
  await sim.waitFor(new RegExp(`live cachecons with ${robots} robots`), 180000);
  const monitor = await startMonitor(hub.addr, 'bench-monitor-swarm');
  procs.push(monitor);
  browser = await launchBrowser({ width: 1400, height: 900 });
  const { page } = browser;
  await page.goto(monitor.url);
  await until(page, (n) => window.colony.drawn.robots === n && window.colony.drawn.pucks === 10 * n,
    robots, 180000, `no ${robots} robots on the page`);

  const sample = () => page.evaluate(() => {
    const c = window.colony;
    return {
      t: performance.now(), frames: c.frames, draws: c.draws, drawn: c.framesDrawn, step: c.step,
      bodies: c.bodyFrames, whole: c.framesWhole, missing: c.framesMissing, drawMs: c.drawMs,
      raster: c.raster, robots: c.drawn.robots, pucks: c.drawn.pucks,
    };
  });
  // Each run twice: as the page runs (a redraw for each new snapshot), then redrawing the
  // whole arena every animation frame (what drawing alone holds, new data or not).
  const modes = [];
  for (let run = 1; run <= runs; run++) modes.push([run, false], [run, true]);
  for (const [run, everyFrame] of modes) {
    await page.evaluate((on) => { window.colony.redrawEveryFrame = on; }, everyFrame);
    await sleep(settleMs);
    const load0 = os.loadavg()[0];
    const a = await sample();
    let maxDraw = 0;
    const end = Date.now() + windowMs;
    while (Date.now() < end) {
      await sleep(500);
      maxDraw = Math.max(maxDraw, (await sample()).drawMs);
    }
    const b = await sample();
    const secs = (b.t - a.t) / 1000;
    const rate = (k) => round1((b[k] - a[k]) / secs);
    const figure = {
      run, mode: everyFrame ? 'redraw every animation frame' : 'redraw on new data', robots, pucks: 10 * robots, speed, window_s: round1(secs),
      animation_fps: rate('frames'),
      redraws_per_s: rate('draws'),
      world_frames_drawn_per_s: rate('drawn'),
      world_steps_per_s: rate('step'),
      whole_frames_at_monitor_per_s: rate('whole'),
      frames_missing_in_window: b.missing - a.missing,
      frames_missing_total: b.missing,
      frames_whole_total: b.whole,
      max_draw_ms: round1(maxDraw),
      drawn: { robots: b.robots, pucks: b.pucks, as_pixels: b.raster },
      load_avg_1min: [round1(load0), round1(os.loadavg()[0])],
      cpus: os.cpus().length, cpu: os.cpus()[0]?.model,
    };
    console.log(`# MONITOR_SWARM ${JSON.stringify(figure)}`);
    console.log(`monitor-swarm run ${run} (${figure.mode}): ${robots} robots, ${10 * robots} pucks, ${figure.window_s} s: `
      + `page ${figure.animation_fps} animation frames/s, ${figure.redraws_per_s} redraws/s, `
      + `${figure.world_frames_drawn_per_s} world frames drawn/s; world ${figure.world_steps_per_s} steps/s, `
      + `${figure.whole_frames_at_monitor_per_s} whole frames/s at the monitor, `
      + `${figure.frames_missing_in_window} frames missing in the window (${b.missing} of ${b.whole + b.missing} in all); `
      + `slowest redraw ${figure.max_draw_ms} ms`);
  }
  await screenshot(page, `bench-${robots}-robots`);
  if (browser.errors.length) {
    console.log(`monitor-swarm: script errors on the page: ${JSON.stringify(browser.errors)}`);
    process.exitCode = 1;
  }
} finally {
  if (browser) await browser.close();
  for (const p of procs.reverse()) await p.stop();
}

function round1(v) {
  return Number(v.toFixed(1));
}
