// The game page in a real browser against a real match: `colony game ctf
// --player red --speed 4` (hub, monitor, simulated battlefield, game server,
// one hub client per robot, a scripted blue) with red played from the page
// in Debian's headless Chromium. Screenshots go to test-artifacts/browser/.
// Every wait is for an event, with room for a loaded machine.
import assert from 'node:assert/strict';
import { after, before, describe, test } from 'node:test';
import {
  SPACING_CM, centroid, launchBrowser, screenshot, sleep, spread, squadOf as squadIn, startGame, untilGame,
} from './lib.mjs';

describe('the game page, playing red against the scripted blue', { concurrency: false }, () => {
  let match;
  let browser;
  let page;
  let url;

  before(async () => {
    // As printed: the page's address with the team and the monitor's token.
    ({ match, url } = await startGame('game-ctf', ['--player', 'red', '--speed', '4']));
    browser = await launchBrowser({ width: 1400, height: 900 });
    page = browser.page;
    await page.goto(url);
  });

  after(async () => {
    if (browser) await browser.close();
    if (match) await match.stop('SIGINT');
  });

  const until = (fn, arg, timeoutMs, what) => untilGame(page, fn, arg, timeoutMs, what);
  const squadOf = (team, name) => squadIn(page, team, name);

  test('the page shows the battlefield, both teams and red\'s squads', async () => {
    await until(() => {
      const g = window.colonyGame;
      return g.connected && g.map && g.state && g.state.robots.length > 0 && !g.stale
        && g.state.squads.some((q) => q.team === 'red');
    }, undefined, 60000, 'no map and game state on the page');
    const info = await page.evaluate(() => {
      const g = window.colonyGame;
      return {
        team: g.team, map: g.map, teams: g.state.teams.map((t) => t.name),
        red: g.state.robots.filter((r) => r.team === 'red').length,
        blue: g.state.robots.filter((r) => r.team === 'blue').length,
        squads: [...document.querySelectorAll('#squads [data-squad]')].map((e) => e.dataset.squad),
      };
    });
    assert.equal(info.team, 'red');
    assert.deepEqual(info.teams.slice().sort(), ['blue', 'red']);
    assert.ok(info.map.width === 64 && info.map.height === 48, `the ctf map is 64 x 48 cells (${info.map.width} x ${info.map.height})`);
    assert.ok(info.red > 0 && info.blue > 0, `robots on both sides (red ${info.red}, blue ${info.blue})`);
    assert.ok(info.squads.length >= 1, 'red\'s squads are listed');
    assert.deepEqual(browser.errors, [], 'no script errors');
    await screenshot(page, 'g1-game-start');
  });

  test('red\'s page is not sent blue\'s squads, orders, paths or reasons, and is live', async () => {
    await until(() => {
      const g = window.colonyGame;
      return g.state && g.state.robots.some((r) => r.team === 'blue' && r.alive);
    }, undefined, 30000, 'no blue robots on the page');
    // Several states, so a plan blue makes meanwhile would show.
    const seen = await page.evaluate(async () => {
      const out = { squads: [], robots: [], heard: [], chip: '', select: false };
      for (let i = 0; i < 10; i++) {
        const g = window.colonyGame;
        out.squads.push(...g.state.squads.filter((q) => q.team !== 'red').map((q) => q.name));
        out.robots.push(...g.state.robots.filter((r) => r.team !== 'red' && (r.squad || r.behaviour || r.reason)).map((r) => r.id));
        out.heard.push(g.heard);
        await new Promise((r) => setTimeout(r, 150));
      }
      out.chip = document.getElementById('conn').textContent;
      out.select = document.getElementById('team').disabled;
      return out;
    });
    assert.deepEqual(seen.squads, [], 'blue\'s squads reached red\'s page');
    assert.deepEqual(seen.robots, [], 'blue robots\' squads, behaviours or reasons reached red\'s page');
    assert.ok(seen.heard.includes(true), `the game server reads red's orders (heard ${seen.heard})`);
    assert.equal(seen.chip, 'live');
    assert.ok(seen.select, 'a page opened for red cannot switch to blue\'s view');
  });

  test('labels do not overlap, base names are drawn over the robots, and the terrain has a legend', async () => {
    await until(() => window.colonyGame.labels.length > 2, undefined, 15000, 'no labels drawn');
    const seen = await page.evaluate(() => ({
      labels: window.colonyGame.labels,
      legend: window.colonyGame.legend,
      shown: !document.getElementById('legend').hidden,
      water: window.colonyGame.map && (window.colonyGame.state && true),
    }));
    const overlaps = [];
    for (let i = 0; i < seen.labels.length; i++) {
      for (let j = i + 1; j < seen.labels.length; j++) {
        const a = seen.labels[i];
        const b = seen.labels[j];
        if (a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1) overlaps.push(`${a.text} / ${b.text}`);
      }
    }
    assert.deepEqual(overlaps, [], 'labels drawn over each other');
    const texts = seen.labels.map((l) => l.text);
    assert.ok(texts.includes('red base') && texts.includes('blue base'), `base names are drawn: ${texts}`);
    assert.ok(seen.shown && seen.legend.includes('open ground') && seen.legend.some((n) => /wall/.test(n)),
      `a legend for the terrain: ${seen.legend}`);
  });

  test('red\'s first squad, in a wedge, attacks a clicked blue robot: it moves, in formation, along a planned path', async () => {
    const name = await page.evaluate(() => window.colonyGame.state.squads.find((q) => q.team === 'red').name);
    await page.locator(`#squads [data-squad="${name}"] .head`).click();
    await until((n) => window.colonyGame.selected === n, name, 15000, `squad ${name} not selected`);
    await page.selectOption('#formation', 'wedge');

    // The blue robot nearest the squad, clicked where it stands now.
    const target = await page.evaluate((n) => {
      const rs = window.colonyGame.state.robots.filter((r) => r.alive);
      const mine = rs.filter((r) => r.team === 'red' && r.squad === n);
      const cx = mine.reduce((a, r) => a + r.x, 0) / mine.length;
      const cy = mine.reduce((a, r) => a + r.y, 0) / mine.length;
      const blue = rs.filter((r) => r.team === 'blue');
      blue.sort((a, b) => Math.hypot(a.x - cx, a.y - cy) - Math.hypot(b.x - cx, b.y - cy));
      return blue[0].id;
    }, name);
    const before = await squadOf('red', name);
    assert.ok(before.robots.length >= 2, `squad ${name} has robots to keep in formation (${before.robots.length})`);
    const at = await page.evaluate((id) => {
      const r = window.colonyGame.state.robots.find((x) => x.id === id);
      return window.colonyGame.worldToClient(r.x, r.y);
    }, target);
    await page.mouse.click(at.x, at.y);
    const sent = await until(() => {
      const g = window.colonyGame;
      return g.lastReply && g.lastReply.to === 'squad' && g.lastCommand && g.lastReply;
    }, undefined, 15000, 'no answer to the attack order');
    assert.ok(sent.ok, `the monitor accepted the order: ${sent.msg}`);
    const cmd = await page.evaluate(() => window.colonyGame.lastCommand);
    assert.deepEqual(cmd, { t: 'squad', team: 'red', squad: name, do: 'attack', robot: target, formation: 'wedge' });

    // The game took it: the squad's order and formation change.
    await until(([n, id]) => {
      const q = window.colonyGame.state.squads.find((x) => x.team === 'red' && x.name === n);
      return q && q.order === `attack robot ${id}` && q.formation === 'wedge';
    }, [name, target], 30000, `squad ${name} did not take "attack robot ${target}" in a wedge`);
    const start = await squadOf('red', name);
    const c0 = centroid(start.robots);

    // It moves off, keeps its formation, and has a planned path.
    // The robots may start scattered and gather on the way: wait for the
    // formation to hold for three samples in a row (0.6 s), not one lucky one.
    const t0 = Date.now();
    let pathSeen = 0;
    let last = start;
    let moved = 0;
    let worst = 0;
    let held = 0;
    while (Date.now() - t0 < 60000) {
      await sleep(200);
      last = await squadOf('red', name);
      if (last.robots.length < 2) break;
      pathSeen = Math.max(pathSeen, last.path.length);
      const c = centroid(last.robots);
      moved = Math.hypot(c[0] - c0[0], c[1] - c0[1]);
      worst = spread(last.robots);
      held = worst <= 3 * SPACING_CM ? held + 1 : 0;
      if (moved > 40 && held >= 3 && pathSeen >= 2) break;
    }
    console.log(`# squad ${name} attacking robot ${target}: moved ${moved.toFixed(0)} cm in ${((Date.now() - t0) / 1000).toFixed(1)} s, `
      + `largest gap to a mate ${worst.toFixed(0)} cm, path of ${pathSeen} points, order "${last.order}", behaviour "${last.behaviour}"`);
    assert.ok(last.robots.length >= 2, `squad ${name} still has robots (${JSON.stringify(last.robots)})`);
    assert.ok(moved > 40, `the squad's centroid moved ${moved.toFixed(1)} cm (more than 40 wanted)`);
    assert.ok(worst <= 3 * SPACING_CM, `every robot within ${3 * SPACING_CM} cm of a squad mate (largest gap ${worst.toFixed(1)} cm): ${JSON.stringify(last.robots)}`);
    assert.ok(pathSeen >= 2, `a planned path of 2 or more points was drawn (${pathSeen})`);
    assert.equal(last.formation, 'wedge');
    assert.deepEqual(browser.errors, [], 'no script errors');
    await screenshot(page, 'g2-squad-attacking');
  });

  test('a command the page refuses never reaches the game, and Stop halts the squad', async () => {
    const reply = await page.evaluate(() => new Promise((resolve) => {
      window.colonyGame.send({ t: 'squad', team: 'red', squad: 'no such squad', do: 'stop' });
      const t0 = Date.now();
      const poll = setInterval(() => {
        const r = window.colonyGame.lastReply;
        if ((r && !r.ok) || Date.now() - t0 > 15000) { clearInterval(poll); resolve(r); }
      }, 50);
    }));
    assert.ok(reply && !reply.ok && /is not a name/.test(reply.msg), `refused with a reason: ${JSON.stringify(reply)}`);
    assert.match(await page.locator('#game-msg').textContent(), /is not a name/);

    await page.click('#stop');
    const name = await page.evaluate(() => window.colonyGame.selected);
    await until((n) => {
      const q = window.colonyGame.state.squads.find((x) => x.team === 'red' && x.name === n);
      return q && q.order === 'stop';
    }, name, 30000, `squad ${name} did not take "stop"`);
  });
});
