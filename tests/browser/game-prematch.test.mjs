// The game's pre-match screen in a real browser: `colony game ctf --player red --lobby` waits
// while red's player spends the budget on the page (types, health and power points, squads);
// an overspent budget is refused with the reason shown, and once red is ready the match starts
// with the robots as chosen.
import assert from 'node:assert/strict';
import { after, before, describe, test } from 'node:test';
import {
  launchBrowser, screenshot, startGame, untilGame,
} from './lib.mjs';

describe('the game\'s pre-match screen', { concurrency: false }, () => {
  let match;
  let browser;
  let page;

  before(async () => {
    let url;
    ({ match, url } = await startGame('game-prematch', [
      '--player', 'red', '--lobby', '--speed', '2', '--red', 'alpha:infantry', '--blue', 'alpha:scout',
    ], 'set up your team at'));
    browser = await launchBrowser({ width: 1400, height: 900 });
    page = browser.page;
    await page.goto(url);
  });

  after(async () => {
    if (browser) await browser.close();
    if (match) await match.stop('SIGINT');
  });

  const until = (fn, arg, timeoutMs, what) => untilGame(page, fn, arg, timeoutMs, what);

  test('red spends its budget on the page, is refused when it overspends, and plays with what it chose', async () => {
    await until(() => {
      const l = window.colonyGame.lobby;
      return l && l.status === 'drafting' && !document.getElementById('prematch').hidden
        && document.querySelectorAll('#pm-squads .pm-robot').length === 1;
    }, undefined, 60000, 'no pre-match screen');
    assert.equal(await page.textContent('#pm-budget'), '30');
    // A match being set up is not a stale one: past the two seconds that would make it so.
    await new Promise((r) => setTimeout(r, 2500));
    const chrome = await page.evaluate(() => ({
      chip: document.getElementById('conn').textContent,
      cls: document.getElementById('conn').className,
      banners: document.getElementById('banners').textContent,
    }));
    assert.equal(chrome.chip, 'pre-match');
    assert.ok(!/bad/.test(chrome.cls), `the chip is not an alarm: ${chrome.cls}`);
    assert.ok(!/stale/i.test(chrome.banners), `no stale banner before the match: ${chrome.banners}`);

    // One squad: a tank with 2 health and 1 power points, and a scout with 1 health point.
    const squad = page.locator('#pm-squads .pm-squad').first();
    await squad.locator('.pm-name').fill('front');
    await squad.locator('.pm-robot').first().locator('.pm-kind').selectOption('tank');
    await squad.locator('.pm-robot').first().locator('.pm-health').fill('2');
    await squad.locator('.pm-robot').first().locator('.pm-power').fill('1');
    await squad.locator('.pm-add-robot').click();
    await squad.locator('.pm-robot').nth(1).locator('.pm-kind').selectOption('scout');
    await squad.locator('.pm-robot').nth(1).locator('.pm-health').fill('1');
    assert.equal(await page.textContent('#pm-cost'), String(5 + 3 + 2 + 1));

    // Too much: a second squad of two tanks at full health and power.
    await page.click('#pm-add-squad');
    const rich = page.locator('#pm-squads .pm-squad').nth(1);
    for (let k = 0; k < 2; k++) {
      if (k > 0) await rich.locator('.pm-add-robot').click();
      const row = rich.locator('.pm-robot').nth(k);
      await row.locator('.pm-kind').selectOption('tank');
      await row.locator('.pm-health').fill('5');
      await row.locator('.pm-power').fill('5');
    }
    assert.equal(await page.textContent('#pm-cost'), String(11 + 30));
    assert.ok(await page.locator('#pm-cost.over').count(), 'the cost shows as over the budget');
    await page.click('#pm-ready');
    await until(() => {
      const el = document.getElementById('refusal');
      return !el.hidden && /red setup: team red costs 41 points; the budget is 30/.test(el.textContent);
    }, undefined, 15000, 'the overspent setup was not refused with its reason');
    const lobby = await page.evaluate(() => window.colonyGame.lobby.teams.find((t) => t.name === 'red'));
    assert.equal(lobby.ready, false, 'a refused setup is not ready');
    assert.equal(lobby.setup, 'alpha:infantry', 'a refused setup changes nothing');
    assert.equal(await page.locator('#pm-squads .pm-squad').count(), 2, 'the player\'s draft is kept');
    await screenshot(page, 'g6-prematch-refused');

    // Within the budget: the second squad goes, and red is ready.
    await rich.locator('.pm-del-squad').click();
    assert.equal(await page.textContent('#pm-cost'), '11');
    await page.click('#pm-ready');

    const robots = await until(() => {
      const s = window.colonyGame.state;
      const red = s && s.robots.filter((r) => r.team === 'red');
      return red && red.length === 2 && red;
    }, undefined, 60000, 'the match did not start with red\'s robots');
    const seen = robots.map((r) => ({ squad: r.squad, kind: r.kind, health: r.max_health, power: r.power }));
    assert.deepEqual(seen, [
      { squad: 'front', kind: 'tank', health: 168, power: 18 },
      { squad: 'front', kind: 'scout', health: 48, power: 4 },
    ]);
    await until(() => document.getElementById('prematch').hidden, undefined, 15000, 'the pre-match screen stayed');
    await until(() => [...document.querySelectorAll('#squads [data-squad]')].map((e) => e.dataset.squad).join() === 'front', undefined, 15000, 'red\'s squad front is not listed');
    await screenshot(page, 'g7-match-as-chosen');
    assert.deepEqual(browser.errors, [], 'no script errors');
  });
});
