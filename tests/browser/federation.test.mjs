// The monitor on one site shows the robots of another, through its own hub:
// site "lab" runs a hub and the live swarm (`colony sort live`), site "ops"
// runs a hub and the monitor, and a `colony bridge` beside each hub joins
// them over Zenoh (peers on loopback TCP). The page is the ordinary monitor,
// joined to the ops hub only.
import assert from 'node:assert/strict';
import { after, before, describe, test } from 'node:test';
import {
  ColonyProcess, colony, freeTcpPort, launchBrowser, screenshot, sleep, startHub, startMonitor, until,
} from './lib.mjs';

describe('the monitor across two sites bridged over Zenoh', { concurrency: false }, () => {
  const procs = [];
  let browser;
  let page;
  let ops;

  before(async () => {
    const lab = await startHub();
    ops = await startHub();
    procs.push(lab, ops);
    const port = await freeTcpPort();
    procs.push(new ColonyProcess('bridge-lab', ['bridge', '--hub', lab.addr, '--site', 'lab', '--listen', `tcp/127.0.0.1:${port}`]));
    procs.push(new ColonyProcess('bridge-ops', ['bridge', '--hub', ops.addr, '--site', 'ops', '--connect', `tcp/127.0.0.1:${port}`]));
    const sim = new ColonyProcess('sort-live-lab', ['sort', 'live', '--hub', lab.addr, '--speed', '5']);
    procs.push(sim);
    await sim.waitFor(/live cachecons with 4 robots/);
    const monitor = await startMonitor(ops.addr, 'monitor-ops');
    procs.push(monitor);
    browser = await launchBrowser();
    page = browser.page;
    await page.goto(monitor.url);
  });

  after(async () => {
    if (browser) await browser.close();
    for (const p of procs.reverse()) await p.stop();
  });

  test('the page joined to the ops hub draws the lab\'s 4 robots and 40 pucks, moving', async () => {
    await until(page, () => window.colony.robots === 4 && window.colony.pucks === 40, undefined, 60000,
      'the lab\'s robots never reached the ops monitor');
    const step = await page.evaluate(() => window.colony.step);
    await until(page, (s) => window.colony.step > s, step, 30000, 'the lab\'s world stopped advancing at ops');
    await screenshot(page, 'f-ops-monitor-shows-lab');
    // The ops hub shows the bridge, and the lab's vision packets published into it.
    // (The bridge brings its about text up to date once a second.)
    let status = await colony(['status', '--hub', ops.addr]);
    for (let i = 0; i < 50 && !/imports \d+ /.test(status); i++) {
      await sleep(200);
      status = await colony(['status', '--hub', ops.addr]);
    }
    assert.match(status, /bridge ops run [0-9a-f]{16}: zenoh peer; exports [^;]*; imports \d+ /, status);
    assert.match(status, /\n\s+vision\s+[1-9]\d* packets/, status);
  });
});
