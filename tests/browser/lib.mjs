// Shared by the browser tests and the screenshot script: the real colony
// processes (hub, live simulator, monitor) and Debian's headless Chromium.
import { spawn, execFile } from 'node:child_process';
import crypto from 'node:crypto';
import dgram from 'node:dgram';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const here = path.dirname(fileURLToPath(import.meta.url));
export const ROOT = path.resolve(here, '..', '..');
export const ARTIFACTS = path.join(ROOT, 'test-artifacts', 'browser');
export const CHROMIUM = '/usr/bin/chromium';

/** The colony binary under test: $COLONY_BIN (the Rust test sets it). */
export function colonyBin() {
  const bin = process.env.COLONY_BIN;
  if (!bin) {
    throw new Error('set COLONY_BIN to the colony binary (cargo test sets it: `cargo test -p colony --test browser`)');
  }
  if (!fs.existsSync(bin)) throw new Error(`COLONY_BIN=${bin} does not exist`);
  return bin;
}

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** A UDP port on loopback that was free a moment ago. */
export function freeUdpPort() {
  return new Promise((resolve, reject) => {
    const s = dgram.createSocket('udp4');
    s.on('error', reject);
    s.bind(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

/** A TCP port on loopback that was free a moment ago. */
export function freeTcpPort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.on('error', reject);
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

/**
 * A colony process whose output goes to test-artifacts/browser/<name>.log;
 * `waitFor` (a RegExp) resolves with its first match on stdout or stderr.
 */
export class ColonyProcess {
  constructor(name, args) {
    fs.mkdirSync(ARTIFACTS, { recursive: true });
    this.name = name;
    this.args = args;
    this.log = fs.createWriteStream(path.join(ARTIFACTS, `${name}.log`), { flags: 'a' });
    this.log.write(`\n$ colony ${args.join(' ')}\n`);
    this.child = spawn(colonyBin(), args, {
      stdio: ['ignore', 'pipe', 'pipe'],
      env: { ...process.env, NO_COLOR: '1', COLONY_LOG: process.env.COLONY_LOG || 'info' },
    });
    this.text = '';
    this.exited = new Promise((resolve) => this.child.on('exit', (code, signal) => resolve({ code, signal })));
    for (const stream of [this.child.stdout, this.child.stderr]) {
      stream.on('data', (d) => {
        this.text += d.toString();
        if (this.text.length > 1e6) this.text = this.text.slice(-5e5);
        this.log.write(d);
      });
    }
  }

  async waitFor(re, timeoutMs = 20000) {
    const until = Date.now() + timeoutMs;
    for (;;) {
      const m = this.text.match(re);
      if (m) return m;
      if (this.child.exitCode !== null) {
        throw new Error(`colony ${this.args.join(' ')} exited (${this.child.exitCode}) before printing ${re}:\n${this.text}`);
      }
      if (Date.now() > until) throw new Error(`colony ${this.args.join(' ')} printed no ${re} within ${timeoutMs} ms:\n${this.text}`);
      await sleep(50);
    }
  }

  /** SIGTERM (each colony command stops cleanly on it), then SIGKILL. */
  async stop(signal = 'SIGTERM') {
    if (this.child.exitCode === null && this.child.signalCode === null) {
      this.child.kill(signal);
      const done = await Promise.race([this.exited, sleep(5000).then(() => null)]);
      if (!done) {
        this.child.kill('SIGKILL');
        await this.exited;
      }
    }
    this.log.end();
  }
}

/**
 * The key the tests' hubs and monitors share, so the monitor's override may
 * raise the hub's minimum priority (the hub takes that from a console only).
 */
let keyFile;
function sharedKey() {
  if (!keyFile) {
    const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'colony-key-'));
    keyFile = path.join(dir, 'colony.key');
    fs.writeFileSync(keyFile, crypto.randomBytes(32).toString('hex') + '\n', { mode: 0o600 });
  }
  return keyFile;
}

/** `colony hub` on a loopback port (a free one unless given), with `extra` arguments. */
export async function startHub(port, extra = []) {
  const p = port ?? (await freeUdpPort());
  const hub = new ColonyProcess('hub', ['hub', '--bind', `127.0.0.1:${p}`, '--key', sharedKey(), ...extra]);
  await hub.waitFor(/addr=/);
  hub.addr = `127.0.0.1:${p}`;
  hub.port = p;
  return hub;
}

/**
 * `colony monitor` joined to `hubAddr`, on a free loopback port; resolves with
 * the URL it prints (with its token: the page needs it).
 */
export async function startMonitor(hubAddr, name = 'monitor') {
  const m = new ColonyProcess(name, ['monitor', '--hub', hubAddr, '--bind', '127.0.0.1:0', '--key', sharedKey()]);
  const [, url] = await m.waitFor(/(http:\/\/127\.0\.0\.1:\d+\/\?token=[0-9a-f]{32})\s/);
  m.url = url;
  return m;
}

/** Runs a colony command to its end; resolves with its stdout. */
export function colony(args, timeoutMs = 15000) {
  return new Promise((resolve, reject) => {
    execFile(colonyBin(), args, { timeout: timeoutMs, env: { ...process.env, NO_COLOR: '1' } }, (err, stdout, stderr) => {
      if (err) reject(new Error(`colony ${args.join(' ')}: ${err.message}\n${stderr}`));
      else resolve(stdout);
    });
  });
}

/** Debian's Chromium, headless, with a fresh profile; resolves with { context, page, close }. */
export async function launchBrowser(viewport = { width: 1400, height: 900 }) {
  if (!fs.existsSync(CHROMIUM)) {
    throw new Error(`${CHROMIUM} is missing: the browser tests need Debian's chromium (.ci/run installs it: apt-get install chromium)`);
  }
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'colony-chromium-'));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    viewport,
    args: [
      '--headless',
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
    ],
  });
  const page = context.pages()[0] ?? (await context.newPage());
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  return {
    context,
    page,
    errors,
    async close() {
      await context.close();
      fs.rmSync(profile, { recursive: true, force: true });
    },
  };
}

/** Saves a screenshot as test-artifacts/browser/<name>.png. */
export async function screenshot(page, name) {
  fs.mkdirSync(ARTIFACTS, { recursive: true });
  const file = path.join(ARTIFACTS, `${name}.png`);
  await page.screenshot({ path: file });
  return file;
}

/** Polls `fn` in the page until it returns something truthy. */
export async function until(page, fn, arg, timeoutMs, what) {
  try {
    const handle = await page.waitForFunction(fn, arg, { timeout: timeoutMs, polling: 100 });
    return await handle.jsonValue();
  } catch (e) {
    const state = await page.evaluate(() => {
      const c = window.colony;
      return c && { robots: c.robots, pucks: c.pucks, step: c.step, drawn: c.drawn, held: c.held, connected: c.connected, hubStale: c.hubStale, visionStale: c.visionStale, lastReply: c.lastReply };
    }).catch(() => null);
    throw new Error(`${what} within ${timeoutMs} ms (page: ${JSON.stringify(state)}): ${e.message.split('\n')[0]}`);
  }
}

// ---- the game page ------------------------------------------------------------------

/** The formation's spacing: a squad in formation keeps every robot within three spacings of its nearest mate. */
export const SPACING_CM = 22;

/**
 * Starts `colony game ARGS` on free ports with the repository's Capture the Flag map, and waits for
 * the page address it prints after `lead` (`open` for a match, `set up your team at` for a pre-match).
 */
export async function startGame(name, args, lead = 'open') {
  const match = new ColonyProcess(name, [
    'game', 'ctf', '--map', path.join(ROOT, 'maps', 'ctf.map'), ...args,
    '--hub-bind', `127.0.0.1:${await freeUdpPort()}`,
    '--monitor-bind', `127.0.0.1:${await freeTcpPort()}`,
  ]);
  const [, url] = await match.waitFor(new RegExp(`${lead} (http://127\\.0\\.0\\.1:\\d+/game\\?team=\\w+&token=[0-9a-f]{32})\\s`), 60000);
  return { match, url };
}

/** Polls the game page until `fn` returns something truthy; on a timeout, says what the page had. */
export async function untilGame(page, fn, arg, timeoutMs, what) {
  try {
    const h = await page.waitForFunction(fn, arg, { timeout: timeoutMs, polling: 100 });
    return await h.jsonValue();
  } catch (e) {
    const seen = await page.evaluate(() => {
      const g = window.colonyGame;
      return g && {
        connected: g.connected, stale: g.stale, team: g.team, selected: g.selected, picked: g.picked, map: g.map && [g.map.width, g.map.height, g.map.cell],
        squads: g.state && g.state.squads, lastReply: g.lastReply, lastCommand: g.lastCommand, refusal: g.refusal, chat: g.chat,
      };
    }).catch(() => null);
    throw new Error(`${what} within ${timeoutMs} ms (page: ${JSON.stringify(seen)}): ${e.message.split('\n')[0]}`);
  }
}

/** A squad as the game page has it, with its living robots as [id, x, y]. */
export const squadOf = (page, team, name) => page.evaluate(([t, n]) => {
  const s = window.colonyGame.state;
  const q = s.squads.find((x) => x.team === t && x.name === n);
  const robots = s.robots.filter((r) => r.team === t && r.squad === n && r.alive).map((r) => [r.id, r.x, r.y]);
  return { ...q, robots, time: s.time };
}, [team, name]);

/** The centroid of robots given as [id, x, y]. */
export const centroid = (robots) => [
  robots.reduce((a, r) => a + r[1], 0) / robots.length,
  robots.reduce((a, r) => a + r[2], 0) / robots.length,
];

/** The largest distance from a robot to its nearest squad mate. */
export const spread = (robots) => Math.max(...robots.map((r) => Math.min(
  ...robots.filter((o) => o !== r).map((o) => Math.hypot(o[1] - r[1], o[2] - r[2])),
)));
