// The game page's orders beyond whole squads, in a real browser against a real match
// (`colony game ctf --player red,blue`: people on both sides, so nothing moves unordered): a drawn path, one robot
// ordered alone, a squad split in two and sent two ways, a robot driven with the keys, team
// chat between two red pages (and not to a blue one), and a refusal with its sound.
import assert from 'node:assert/strict';
import { after, before, describe, test } from 'node:test';
import {
  SPACING_CM, centroid, launchBrowser, screenshot, sleep, spread, squadOf as squadIn, startGame, untilGame,
} from './lib.mjs';

describe('the game page\'s orders: paths, single robots, split, merge, driving, chat', { concurrency: false }, () => {
  let match;
  let browser;
  let page;
  let url;

  before(async () => {
    ({ match, url } = await startGame('game-orders', [
      '--player', 'red,blue', '--speed', '2',
      '--red', 'alpha:infantry,infantry,infantry,infantry bravo:scout,scout', '--blue', 'alpha:tank',
    ]));
    browser = await launchBrowser({ width: 1400, height: 900 });
    page = browser.page;
    await page.goto(url);
    await until(() => {
      const g = window.colonyGame;
      return g.connected && g.map && g.state && !g.stale && g.state.squads.some((q) => q.team === 'red' && q.name === 'alpha');
    }, undefined, 60000, 'no game on the page');
  });

  after(async () => {
    if (browser) await browser.close();
    if (match) await match.stop('SIGINT');
  });

  const until = (fn, arg, timeoutMs, what) => untilGame(page, fn, arg, timeoutMs, what);
  const squadOf = (team, name) => squadIn(page, team, name);
  const client = (x, y) => page.evaluate(([wx, wy]) => window.colonyGame.worldToClient(wx, wy), [x, y]);
  const selectSquad = async (name) => {
    // A press on the selected squad lets it go: press only to select.
    if (await page.evaluate((n) => window.colonyGame.selected !== n, name)) {
      await page.locator(`#squads [data-squad="${name}"] .head`).click();
    }
    await until((n) => window.colonyGame.selected === n, name, 15000, `squad ${name} not selected`);
  };
  const near = (robots, [x, y], cm) => robots.length > 0 && Math.hypot(centroid(robots)[0] - x, centroid(robots)[1] - y) < cm;

  // Waits until the squad's living robots are near `at` and in formation for three samples running.
  async function arrives(name, at, what) {
    const t0 = Date.now();
    let held = 0;
    let last = null;
    while (Date.now() - t0 < 90000) {
      await sleep(200);
      last = await squadOf('red', name);
      const formed = last.robots.length < 2 || spread(last.robots) <= 3 * SPACING_CM;
      held = near(last.robots, at, 80) && formed ? held + 1 : 0;
      if (held >= 3) return last;
    }
    throw new Error(`${what}: squad ${name} did not arrive in formation near ${at}: ${JSON.stringify(last)}`);
  }

  test('a path drawn by dragging across the map is followed by the squad in formation', async () => {
    await selectSquad('alpha');
    await page.selectOption('#formation', 'line');
    const start = await squadOf('red', 'alpha');
    const [cx, cy] = centroid(start.robots);
    // East along the south of the map, then up: open ground all the way.
    const drawn = [[cx, cy], [cx + 150, 150], [500, 150], [700, 250]];
    const first = await client(...drawn[0]);
    await page.mouse.move(first.x, first.y);
    await page.mouse.down();
    for (let i = 1; i < drawn.length; i++) {
      const p = await client(...drawn[i]);
      await page.mouse.move(p.x, p.y, { steps: 12 });
    }
    await page.mouse.up();
    const cmd = await until(() => {
      const g = window.colonyGame;
      return g.lastCommand && g.lastCommand.do === 'path' && g.lastReply && g.lastReply.to === 'squad' && g.lastCommand;
    }, undefined, 15000, 'no path sent');
    assert.equal(cmd.t, 'squad');
    assert.equal(cmd.squad, 'alpha');
    assert.equal(cmd.formation, 'line');
    assert.ok(cmd.points.length >= 4 && cmd.points.length <= 64, `the stroke's points, thinned: ${cmd.points.length}`);
    await until(() => {
      const q = window.colonyGame.state.squads.find((x) => x.team === 'red' && x.name === 'alpha');
      return q && q.order.startsWith('path of') && q.formation === 'line';
    }, undefined, 30000, 'alpha did not take the drawn path');
    await screenshot(page, 'g3-path-drawn');
    const end = await arrives('alpha', [700, 250], 'the drawn path');
    assert.equal(end.robots.length, 4, 'all four robots followed');
    assert.deepEqual(browser.errors, [], 'no script errors');
  });

  test('one robot ordered alone goes its way while its squad stays', async () => {
    const before = await squadOf('red', 'bravo');
    assert.equal(before.robots.length, 2);
    const [id] = before.robots[0];
    await page.locator(`#squads [data-robot="${id}"]`).click();
    await until((r) => window.colonyGame.picked === r, id, 15000, `robot ${id} not picked`);
    const goal = [400, 100];
    const at = await client(...goal);
    await page.mouse.click(at.x, at.y);
    const cmd = await until(() => window.colonyGame.lastCommand, undefined, 5000, 'no order');
    assert.deepEqual({ t: cmd.t, id: cmd.id, do: cmd.do }, { t: 'robot', id, do: 'goto' });
    await until((r) => {
      const s = window.colonyGame.state;
      return s.robots.find((x) => x.id === r).squad === `robot-${r}`;
    }, id, 30000, `robot ${id} did not leave its squad`);
    const solo = await arrives(`robot-${id}`, goal, 'the robot alone');
    assert.equal(solo.robots.length, 1);
    const bravo = await squadOf('red', 'bravo');
    assert.equal(bravo.robots.length, 1, 'its mate stayed in bravo');
    assert.equal(bravo.order, before.order, 'bravo kept its order');
    assert.ok(near(bravo.robots, centroid(before.robots), 60), `bravo stayed where it was: ${JSON.stringify(bravo.robots)}`);
  });

  test('a squad split in two sends its halves different ways, and they merge again', async () => {
    await selectSquad('alpha');
    await page.click('#split');
    await until(() => window.colonyGame.state.squads.some((q) => q.team === 'red' && q.name === 'alpha-2'), undefined, 30000, 'no squad alpha-2');
    const halves = [await squadOf('red', 'alpha'), await squadOf('red', 'alpha-2')];
    assert.deepEqual(halves.map((h) => h.robots.length), [2, 2]);
    const west = [450, 120];
    const north = [800, 400];
    await selectSquad('alpha');
    let p = await client(...west);
    await page.mouse.click(p.x, p.y);
    await selectSquad('alpha-2');
    p = await client(...north);
    await page.mouse.click(p.x, p.y);
    const [a, b] = [await arrives('alpha', west, 'the first half'), await arrives('alpha-2', north, 'the second half')];
    assert.ok(Math.hypot(centroid(a.robots)[0] - centroid(b.robots)[0], centroid(a.robots)[1] - centroid(b.robots)[1]) > 200);
    await screenshot(page, 'g4-split');
    // alpha-2 is selected: merge it into alpha.
    await page.selectOption('#merge-into', 'alpha');
    await page.click('#merge');
    await until(() => {
      const s = window.colonyGame.state;
      return !s.squads.some((q) => q.name === 'alpha-2') && s.robots.filter((r) => r.team === 'red' && r.squad === 'alpha').length === 4;
    }, undefined, 30000, 'alpha-2 did not merge into alpha');
  });

  test('a robot taken under direct control is driven by the keys and given back', async () => {
    const alpha = await squadOf('red', 'alpha');
    const [id, x0, y0] = alpha.robots[0];
    await page.locator(`#squads [data-robot="${id}"]`).click();
    await until((r) => window.colonyGame.picked === r, id, 15000, `robot ${id} not picked`);
    await page.click('#drive');
    await until((r) => window.colonyGame.driving === r, id, 5000, 'not driving');
    await page.locator('#field').focus();
    await page.keyboard.down('ArrowUp');
    await until(([r, ox, oy]) => {
      const b = window.colonyGame.state.robots.find((x) => x.id === r);
      return Math.hypot(b.x - ox, b.y - oy) > 30 && b.behaviour;
    }, [id, x0, y0], 30000, 'the driven robot did not move');
    await page.keyboard.up('ArrowUp');
    const behaviour = await page.evaluate((r) => window.colonyGame.state.robots.find((x) => x.id === r).reason, id);
    await page.click('#drive');
    const cmd = await until(() => window.colonyGame.lastCommand, undefined, 5000, 'no release');
    assert.deepEqual(cmd, { t: 'robot_release', team: 'red', robot: id });
    await until(() => window.colonyGame.lastReply && window.colonyGame.lastReply.to === 'robot_release' && window.colonyGame.lastReply.ok, undefined, 10000, 'the release was not taken');
    console.log(`# robot ${id} driven; its behaviour while driven: ${behaviour}`);
    assert.equal(await page.evaluate(() => window.colonyGame.driving), null);
  });

  test('a chat line reaches the other red player and not blue, and a refusal is shown and heard', async () => {
    const mate = await browser.context.newPage();
    await mate.goto(url);
    const enemy = await browser.context.newPage();
    await enemy.goto(url.replace('team=red', 'team=blue'));
    for (const p of [mate, enemy]) {
      await untilGame(p, () => window.colonyGame.connected && window.colonyGame.state, undefined, 30000, 'a second page');
    }
    await page.fill('#chat-text', 'hold the bridge');
    await page.press('#chat-text', 'Enter');
    await untilGame(mate, () => window.colonyGame.chat.some((l) => l.text === 'hold the bridge'), undefined, 15000, 'the red mate did not get the chat line');
    await untilGame(page, () => window.colonyGame.chat.some((l) => l.text === 'hold the bridge'), undefined, 15000, 'the writer does not see its own line');
    await sleep(2000);
    assert.deepEqual(await enemy.evaluate(() => window.colonyGame.chat), [], 'blue heard nothing of red\'s chat');
    assert.ok((await mate.evaluate(() => window.colonyGame.sounds)).includes('chat'), 'the mate heard the chat');
    // Switched off, the chat is out of sight and silent.
    await mate.uncheck('#chat-on');
    assert.ok(await mate.locator('#chat-section').isHidden(), 'the chat is hidden when switched off');
    const chimes = await mate.evaluate(() => window.colonyGame.sounds.filter((k) => k === 'chat').length);
    await page.fill('#chat-text', 'and the ford');
    await page.press('#chat-text', 'Enter');
    await untilGame(mate, () => window.colonyGame.chat.some((l) => l.text === 'and the ford'), undefined, 15000, 'the second line');
    assert.equal(await mate.evaluate(() => window.colonyGame.sounds.filter((k) => k === 'chat').length), chimes, 'no chime with the chat off');

    const blue = await page.evaluate(() => window.colonyGame.state.robots.find((r) => r.team === 'blue').id);
    await page.evaluate((id) => window.colonyGame.send({ t: 'robot', team: 'red', id, do: 'stop' }), blue);
    await until((id) => {
      const el = document.getElementById('refusal');
      return !el.hidden && el.textContent.includes(`red robot ${id}: it is not yours`);
    }, blue, 15000, 'no refusal shown');
    await until(() => window.colonyGame.sounds.includes('refused'), undefined, 5000, 'no refusal sound');
    await screenshot(page, 'g5-chat-refusal');
    await mate.close();
    await enemy.close();
    assert.deepEqual(browser.errors, [], 'no script errors');
  });
});
