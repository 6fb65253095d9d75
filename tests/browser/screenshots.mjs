// Takes the README's screenshots of the monitor: `colony demo` at high
// speed, one shot once the swarm is on the page (docs/monitor-start.png) and
// one after some simulated time, when clusters have formed
// (docs/monitor-sorted.png); and the game page (docs/game-client.png):
// `colony game ctf --player red`, red's first squad sent in a wedge to
// attack a blue robot.
//
//   cargo build --release
//   cd tests/browser && npm ci
//   COLONY_BIN=../../target/release/colony node screenshots.mjs [--speed 40] [--minutes 30] [--pages monitor,game]
//
// --minutes is simulated time before the second shot (the world's control
// period is 3/14 s, so a minute is 280 steps); at --speed 40 an hour of
// simulated time takes 90 s (the defaults: half an hour, 45 s).
import fs from 'node:fs';
import path from 'node:path';
import { parseArgs } from 'node:util';
import { ColonyProcess, ROOT, freeTcpPort, freeUdpPort, launchBrowser, sleep, until } from './lib.mjs';

const { values } = parseArgs({
  options: {
    speed: { type: 'string', default: '40' },
    minutes: { type: 'string', default: '30' },
    out: { type: 'string', default: path.join(ROOT, 'docs') },
    pages: { type: 'string', default: 'monitor,game' },
  },
});
const pages = new Set(values.pages.split(','));
const speed = Number(values.speed);
const minutes = Number(values.minutes);
if (!(speed > 0) || !(minutes > 0)) throw new Error('--speed and --minutes must be positive numbers');
if (!process.env.COLONY_BIN) process.env.COLONY_BIN = path.join(ROOT, 'target', 'release', 'colony');
const STEPS_PER_MINUTE = 60 / (3 / 14);

if (pages.has('monitor')) await monitorShots();
if (pages.has('game')) await gameShot();

async function monitorShots() {
  const demo = new ColonyProcess('screenshots-demo', [
    'demo', '--speed', String(speed),
    '--hub-bind', `127.0.0.1:${await freeUdpPort()}`,
    '--monitor-bind', `127.0.0.1:${await freeTcpPort()}`,
  ]);
  let browser;
  try {
    const [, url] = await demo.waitFor(/open (http:\/\/\S+)/);
    browser = await launchBrowser({ width: 1500, height: 940 });
    const { page } = browser;
    await page.goto(url);
    await until(page, () => window.colony.robots === 4 && window.colony.pucks === 40 && window.colony.pc !== null
      && Object.keys(window.colony.channels).length >= 6, undefined, 30000, 'the demo is not on the page');
    await sleep(1000);
    fs.mkdirSync(values.out, { recursive: true });
    const start = path.join(values.out, 'monitor-start.png');
    await page.screenshot({ path: start });
    console.log(`${start}: step ${await page.evaluate(() => window.colony.step)}`);
    const target = Math.round(minutes * STEPS_PER_MINUTE);
    await until(page, (n) => window.colony.step >= n, target, ((target / (speed * 14 / 3)) * 1.5 + 60) * 1000,
      `step ${target} not reached`);
    const sorted = path.join(values.out, 'monitor-sorted.png');
    await page.screenshot({ path: sorted });
    const { step, pc, poses } = await page.evaluate(() => ({ step: window.colony.step, pc: window.colony.pc, poses: window.colony.poses }));
    console.log(`robots (x, y, heading) at the second shot: ${JSON.stringify(poses)}`);
    console.log(`${sorted}: step ${step} (${(step / STEPS_PER_MINUTE).toFixed(0)} simulated minutes), PC ${pc} %`);
  } finally {
    if (browser) await browser.close();
    await demo.stop('SIGINT');
  }
}

async function gameShot() {
  const match = new ColonyProcess('screenshots-game', [
    'game', 'ctf', '--map', path.join(ROOT, 'maps', 'ctf.map'), '--player', 'red', '--speed', '4',
    '--hub-bind', `127.0.0.1:${await freeUdpPort()}`,
    '--monitor-bind', `127.0.0.1:${await freeTcpPort()}`,
  ]);
  let browser;
  try {
    const [, gameUrl] = await match.waitFor(/open (http:\/\/127\.0\.0\.1:\d+\/game\S*)/, 60000);
    browser = await launchBrowser({ width: 1500, height: 940 });
    const { page } = browser;
    await page.goto(gameUrl);
    await page.waitForFunction(() => {
      const g = window.colonyGame;
      return g.map && g.state && !g.stale && g.state.squads.some((q) => q.team === 'red');
    }, undefined, { timeout: 30000, polling: 100 });
    const name = await page.evaluate(() => window.colonyGame.state.squads.find((q) => q.team === 'red').name);
    await page.locator(`#squads [data-squad="${name}"]`).click();
    await page.selectOption('#formation', 'wedge');
    // The blue robot nearest the squad, as in game.test.mjs.
    const at = await page.evaluate((n) => {
      const rs = window.colonyGame.state.robots.filter((r) => r.alive);
      const mine = rs.filter((r) => r.team === 'red' && r.squad === n);
      const cx = mine.reduce((a, r) => a + r.x, 0) / mine.length;
      const cy = mine.reduce((a, r) => a + r.y, 0) / mine.length;
      const blue = rs.filter((r) => r.team === 'blue');
      blue.sort((a, b) => Math.hypot(a.x - cx, a.y - cy) - Math.hypot(b.x - cx, b.y - cy));
      return window.colonyGame.worldToClient(blue[0].x, blue[0].y);
    }, name);
    await page.mouse.click(at.x, at.y);
    await sleep(8000); // under way, in formation, along its path
    fs.mkdirSync(values.out, { recursive: true });
    const file = path.join(values.out, 'game-client.png');
    await page.screenshot({ path: file });
    const order = await page.evaluate((n) => window.colonyGame.state.squads.find((q) => q.team === 'red' && q.name === n).order, name);
    console.log(`${file}: squad ${name}, order "${order}"`);
  } finally {
    if (browser) await browser.close();
    await match.stop('SIGINT');
  }
}
