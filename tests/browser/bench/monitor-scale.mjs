// How fast the monitor page keeps up with a big swarm: 256 robots and 2,560
// pucks (`--scale-robots 256`, arena 1,496 cm wide) at about 13 world steps
// a second (`--speed 2.8`; the control period is 3/14 s), in Debian's
// headless Chromium. Measures, over a window after the swarm is on screen:
// the page's frames a second (requestAnimationFrame), the world's steps a
// second, the snapshots a second that reach the page, and the slowest
// redraw; then kills the hub and times the stale banner. A benchmark, not a
// test (its file name keeps `node --test` away): it asserts nothing, it
// prints figures for BENCHMARKS.md. scripts/bench-monitor builds the release
// binary and runs it.
//
//   COLONY_BIN=target/release/colony node tests/browser/bench/monitor-scale.mjs [--robots 256] [--speed 2.8] [--window 10] [--runs 2]
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';
import {
  ColonyProcess, ROOT, launchBrowser, screenshot, sleep, startHub, startMonitor, until,
} from '../lib.mjs';

const { values } = parseArgs({
  options: {
    robots: { type: 'string', default: '256' },
    speed: { type: 'string', default: '2.8' },
    window: { type: 'string', default: '10' },
    settle: { type: 'string', default: '2' },
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
  // Controllers as threads: 256 robot processes would measure the machine, not the monitor.
  const sim = new ColonyProcess('bench-sort-live', [
    'sort', 'live', '--hub', hub.addr, '--scale-robots', String(robots),
    '--speed', String(speed), '--controllers', 'thread',
  ]);
  procs.push(sim);
  await sim.waitFor(new RegExp(`live cachecons with ${robots} robots`), 120000);
  const monitor = await startMonitor(hub.addr, 'bench-monitor');
  procs.push(monitor);
  browser = await launchBrowser({ width: 1400, height: 900 });
  const { page } = browser;
  await page.goto(monitor.url);
  await until(page, (n) => window.colony.drawn.robots === n && window.colony.drawn.pucks === 10 * n && !window.colony.visionStale,
    robots, 120000, `no ${robots} robots on the page`);

  const sample = () => page.evaluate(() => ({
    t: performance.now(), frames: window.colony.frames, step: window.colony.step,
    worlds: window.colony.worlds, drawMs: window.colony.drawMs,
  }));
  for (let run = 1; run <= runs; run++) {
    await sleep(settleMs); // let the page settle
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
    const figure = {
      run, robots, pucks: 10 * robots, speed, window_s: round1(secs),
      fps: round1((b.frames - a.frames) / secs),
      world_steps_per_s: round1((b.step - a.step) / secs),
      snapshots_per_s: round1((b.worlds - a.worlds) / secs),
      max_draw_ms: round1(maxDraw),
      load_avg_1min: [round1(load0), round1(os.loadavg()[0])],
      cpus: os.cpus().length, cpu: os.cpus()[0]?.model,
    };
    console.log(`# MONITOR_FPS ${JSON.stringify(figure)}`);
    console.log(`monitor-scale run ${run}: ${robots} robots, ${10 * robots} pucks, --speed ${speed}, ${figure.window_s} s: `
      + `page ${figure.fps} frames/s, world ${figure.world_steps_per_s} steps/s, `
      + `${figure.snapshots_per_s} snapshots/s reaching the page, slowest redraw ${figure.max_draw_ms} ms`);
  }
  await screenshot(page, 'bench-256-robots');

  // The stale banner: how long after the hub dies the page says so.
  const killed = Date.now();
  await hub.stop('SIGKILL');
  await until(page, () => !!document.querySelector('#banner-hub') && window.colony.hubStale,
    undefined, 60000, 'no stale banner after the hub was killed');
  const staleMs = Date.now() - killed;
  console.log(`# MONITOR_STALE ${JSON.stringify({ robots, banner_ms: staleMs })}`);
  console.log(`monitor-scale: the stale banner showed ${staleMs} ms after the hub was killed`);
  if (browser.errors.length) {
    console.log(`monitor-scale: script errors on the page: ${JSON.stringify(browser.errors)}`);
    process.exitCode = 1;
  }
} finally {
  if (browser) await browser.close();
  for (const p of procs.reverse()) await p.stop();
}

function round1(v) {
  return Number(v.toFixed(1));
}
