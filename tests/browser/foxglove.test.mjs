// The monitor's Foxglove WebSocket (`/foxglove`, foxglove.websocket.v1) against a live
// `colony demo`, through Foxglove's own client (`FoxgloveClient` from the npm package
// @foxglove/ws-protocol, over the `ws` package): serverInfo and the advertised channels,
// `vision` at the world's rate with receive timestamps, the arena as scene entities, an
// override published by the viewer that holds and drives a robot in the simulator, and
// unsubscribing. Then what a hostile client sends: the gate's refusals and status errors.
// Every wait is for an event (polled until it holds, with a generous deadline), never a fixed
// sleep or a speed: a loaded machine may be slow, but must behave the same.
import assert from 'node:assert/strict';
import { after, before, describe, test } from 'node:test';
import foxglove from '@foxglove/ws-protocol';
import WebSocket from 'ws';
import { spawnSync } from 'node:child_process';
import { ColonyProcess, colonyBin, freeUdpPort, sleep } from './lib.mjs';

const { FoxgloveClient } = foxglove;
const SPEED = 2;

const decoder = new TextDecoder();

/** A vision message's robots, { id: [x, y, theta] }, from colony-schema's JSON. */
function robotsOf(json) {
  const out = {};
  for (const r of json.lines.robot || []) out[r.id] = [r.x, r.y, r.theta];
  return out;
}

async function until(fn, timeoutMs, what) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out: ${what}`);
    await sleep(50);
  }
}

describe('the Foxglove WebSocket, against a live colony demo', { concurrency: false, timeout: 180000 }, () => {
  let demo;
  let wsUrl;
  let client;
  let serverInfo;
  const channels = new Map(); // topic -> channel
  const statuses = [];
  const bySub = new Map(); // subscription id -> [{ ts, json }]

  before(async () => {
    const hubPort = await freeUdpPort();
    demo = new ColonyProcess('foxglove-demo', [
      'demo', '--hub-bind', `127.0.0.1:${hubPort}`, '--monitor-bind', '127.0.0.1:0', '--speed', String(SPEED),
    ]);
    const [, host, token] = await demo.waitFor(/http:\/\/(127\.0\.0\.1:\d+)\/\?token=([0-9a-f]{32})\s/);
    wsUrl = `ws://${host}/foxglove?token=${token}`;
    client = new FoxgloveClient({ ws: new WebSocket(wsUrl, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
    client.on('serverInfo', (info) => { serverInfo = info; });
    client.on('advertise', (list) => { for (const c of list) channels.set(c.topic, c); });
    client.on('status', (s) => statuses.push(s));
    client.on('message', ({ subscriptionId, timestamp, data }) => {
      const list = bySub.get(subscriptionId) || [];
      const json = JSON.parse(decoder.decode(data));
      list.push({ ts: timestamp, json, at: Date.now() });
      if (list.length > 5000) list.shift();
      bySub.set(subscriptionId, list);
    });
    client.on('error', (e) => statuses.push({ level: 2, message: `client error: ${e}` }));
  });

  after(async () => {
    if (client) client.close();
    if (demo) await demo.stop();
  });

  test('serverInfo comes first, then the hub\'s channels as they appear, with their JSON Schemas', async () => {
    await until(() => serverInfo, 20000, 'no serverInfo');
    assert.ok(serverInfo.capabilities.includes('clientPublish'), JSON.stringify(serverInfo));
    assert.deepEqual(serverInfo.supportedEncodings, ['json']);
    await until(() => ['vision', 'radio', 'debug', '/colony/arena'].every((t) => channels.has(t)),
      30000, `channels advertised: ${[...channels.keys()]}`);
    const vision = channels.get('vision');
    assert.equal(vision.encoding, 'json');
    assert.equal(vision.schemaEncoding, 'jsonschema');
    assert.equal(typeof JSON.parse(vision.schema), 'object');
    assert.equal(channels.get('/colony/arena').schemaName, 'foxglove.SceneUpdate');
  });

  test('vision keeps coming as the world steps, each with its receive timestamp', async () => {
    const sub = client.subscribe(channels.get('vision').id);
    await until(() => (bySub.get(sub) || []).length > 0, 20000, 'no vision message');
    // Behaviour, not speed: more messages come, for later and later steps.
    const n0 = bySub.get(sub).length;
    await until(() => bySub.get(sub).length >= n0 + 5, 60000, 'vision stopped coming');
    const steps = bySub.get(sub).map((m) => m.json.lines.step?.[0]?.n).filter((n) => n !== undefined);
    assert.ok(steps.length >= 5, `vision without step numbers: ${JSON.stringify(bySub.get(sub).at(-1).json.lines)}`);
    assert.ok(steps.at(-1) > steps[0], `steps did not advance: ${steps}`);
    const last = bySub.get(sub).at(-1);
    assert.match(last.json.packet, /^@ <vision> /);
    assert.deepEqual(last.json.subjects, ['vision']);
    assert.equal(Object.keys(robotsOf(last.json)).length, 4);
    // Receive timestamps: nanoseconds of the wall clock, increasing.
    const now = BigInt(Date.now()) * 1000000n;
    assert.ok(last.ts > now - 60n * 1000000000n && last.ts <= now + 1000000000n, `timestamp ${last.ts}`);
    const list = bySub.get(sub);
    assert.ok(list.at(-1).ts >= list.at(-2).ts);
    client.unsubscribe(sub);
  });

  test('the arena comes as scene entities: walls, 4 robots with their heading, 40 pucks', async () => {
    const sub = client.subscribe(channels.get('/colony/arena').id);
    const msg = await until(() => (bySub.get(sub) || []).at(-1), 20000, 'no arena scene');
    client.unsubscribe(sub);
    const byId = Object.fromEntries(msg.json.entities.map((e) => [e.id, e]));
    assert.equal(byId.walls.frame_id, 'arena');
    assert.ok(byId.walls.lines[0].points.length > 4);
    assert.equal(byId.robots.cubes.length, 4);
    assert.equal(byId.robots.arrows.length, 4);
    assert.ok('w' in byId.robots.cubes[0].pose.orientation);
    assert.equal(byId.pucks.cylinders.length, 40);
    // The arena's frame is placed in `world`, so a 3D panel has a tree to choose from.
    const fsub = client.subscribe(channels.get('/colony/frames').id);
    const frames = await until(() => (bySub.get(fsub) || []).at(-1), 20000, 'no frame transforms');
    client.unsubscribe(fsub);
    assert.ok(frames.json.transforms.some((t) => t.parent_frame_id === 'world' && t.child_frame_id === 'arena'));
  });

  test('an override the viewer publishes holds a robot and drives it in the simulator', async () => {
    const vision = client.subscribe(channels.get('vision').id);
    const radio = client.subscribe(channels.get('radio').id);
    await until(() => (bySub.get(vision) || []).length > 0, 20000, 'no vision');
    const override = client.advertise({ topic: '/colony/override', encoding: 'json', schemaName: 'colony.Override' });
    const send = (msg) => client.sendMessage(override, new TextEncoder().encode(JSON.stringify(msg)));
    const pose = () => robotsOf(bySub.get(vision).at(-1).json);
    const errorsBefore = statuses.filter((s) => s.level === 2).length;
    send({ t: 'take', ids: [0] });
    // Held and stopped: robot 0 stays put while the others sort (the world obeys priority 10).
    // Wait for the event (a priority-10 stop for robot 0 on radio, then a few more steps of
    // vision), not a time: then it stays put over several further steps.
    const stops = () => (bySub.get(radio) || []).filter((m) => m.json.priority === 10
      && (m.json.lines.cmd || []).some((c) => c.id === 0)).length;
    await until(() => stops() > 0, 20000, 'robot 0 was not held');
    const visionAfter = async (n) => {
      const n0 = bySub.get(vision).length;
      await until(() => bySub.get(vision).length >= n0 + n, 60000, 'vision stopped coming');
    };
    await visionAfter(5);
    const held = pose();
    await visionAfter(10);
    const still = pose();
    const moved = (a, b, id) => Math.hypot(a[id][0] - b[id][0], a[id][1] - b[id][1]);
    assert.ok(moved(held, still, 0) < 3, `robot 0 held still moved ${moved(held, still, 0).toFixed(1)} cm`);
    // Driven forward (repeated, as the page's keys are): it moves.
    for (let i = 0; i < 30; i++) {
      send({ t: 'drive', ids: [0], forward: 1, turn: 0 });
      await sleep(100);
    }
    const driven = pose();
    assert.ok(moved(still, driven, 0) > 5, `robot 0 driven moved only ${moved(still, driven, 0).toFixed(1)} cm`);
    // The monitor published it on radio at the override's priority, for robot 0.
    const cmds = (bySub.get(radio) || []).filter((m) => m.json.priority === 10
      && (m.json.lines.cmd || []).some((c) => c.id === 0 && c.forward === 1));
    assert.ok(cmds.length > 0, 'no priority-10 radio command for robot 0');
    assert.equal(statuses.filter((s) => s.level === 2).length, errorsBefore,
      JSON.stringify(statuses.slice(errorsBefore)));
    send({ t: 'release', ids: [0] });
    client.unadvertise(override);
    client.unsubscribe(radio);
    client.unsubscribe(vision);
  });

  test('a radio packet the viewer publishes (colony-schema JSON) holds its robots through the override', async () => {
    const radio = client.subscribe(channels.get('radio').id);
    const ch = client.advertise({ topic: 'radio', encoding: 'json', schemaName: 'colony.radio' });
    const packet = '@ <radio> 10\ncmd id 1 forward 0 turn 0.5\n';
    const errorsBefore = statuses.filter((s) => s.level === 2).length;
    const mine = () => (bySub.get(radio) || []).filter((m) => m.json.priority === 10
      && (m.json.lines.cmd || []).some((c) => c.id === 1 && c.turn === 0.5));
    await until(() => {
      client.sendMessage(ch, new TextEncoder().encode(JSON.stringify({ packet })));
      return mine().length > 0;
    }, 20000, 'the monitor published no override for robot 1');
    assert.equal(statuses.filter((s) => s.level === 2).length, errorsBefore,
      JSON.stringify(statuses.slice(errorsBefore)));
    const o = client.advertise({ topic: '/colony/override', encoding: 'json', schemaName: 'colony.Override' });
    client.sendMessage(o, new TextEncoder().encode(JSON.stringify({ t: 'release', ids: [1] })));
    client.unadvertise(o);
    client.unadvertise(ch);
    client.unsubscribe(radio);
  });

  test('what a viewer holds is let go when it disconnects, as a page\'s is', async () => {
    const radio = client.subscribe(channels.get('radio').id);
    const other = new FoxgloveClient({ ws: new WebSocket(wsUrl, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
    await new Promise((resolve) => other.on('serverInfo', resolve));
    const o = other.advertise({ topic: '/colony/override', encoding: 'json', schemaName: 'colony.Override' });
    other.sendMessage(o, new TextEncoder().encode(JSON.stringify({ t: 'take', ids: [2] })));
    const holds2 = (m) => m.json.priority === 10 && (m.json.lines.cmd || []).some((c) => c.id === 2);
    await until(() => (bySub.get(radio) || []).some(holds2), 20000, 'robot 2 was not held');
    other.close();
    // Once the bridge hears the connection closed, no more override commands for robot 2:
    // poll until a run of radio packets (the world's own, which keep coming) holds none.
    await until(() => {
      const list = bySub.get(radio) || [];
      const lastHold = list.findLastIndex(holds2);
      return list.length - 1 - lastHold >= 20;
    }, 60000, 'robot 2 still held after its viewer left');
    client.unsubscribe(radio);
  });

  test('after unsubscribing, no more messages come for the subscription', async () => {
    const sub = client.subscribe(channels.get('vision').id);
    await until(() => (bySub.get(sub) || []).length > 2, 20000, 'no vision');
    client.unsubscribe(sub);
    // Messages already in flight may still arrive. The connection handles a client's requests
    // in order, so once a later subscription's messages come, the unsubscribe has taken effect:
    // from then on, none for the old subscription.
    const marker = client.subscribe(channels.get('vision').id);
    await until(() => (bySub.get(marker) || []).length > 0, 20000, 'no vision on the later subscription');
    const n = bySub.get(sub).length;
    await until(() => (bySub.get(marker) || []).length > 10, 60000, 'vision stopped on the later subscription');
    assert.equal(bySub.get(sub).length, n, 'vision kept coming after unsubscribe');
    client.unsubscribe(marker);
  });

  /** A raw client (no Foxglove library) with the given headers; resolves with its frames. */
  function raw(url, headers = {}) {
    return new Promise((resolve) => {
      const ws = new WebSocket(url, ['foxglove.websocket.v1'], { headers });
      const frames = [];
      ws.on('message', (d, binary) => frames.push(binary ? d : JSON.parse(d.toString())));
      ws.on('open', () => resolve({ ws, frames, opened: true }));
      ws.on('unexpected-response', (_req, res) => resolve({ opened: false, status: res.statusCode }));
      ws.on('error', () => resolve({ opened: false }));
    });
  }

  test('the gate refuses another site\'s page and a missing token', async () => {
    const foreign = await raw(wsUrl, { Origin: 'http://evil.example' });
    assert.equal(foreign.opened, false);
    assert.equal(foreign.status, 403);
    const noToken = await raw(wsUrl.replace(/\?token=.*/, ''));
    assert.equal(noToken.status, 403);
  });

  test('viewers past the cap are closed with a reason; the others carry on', async () => {
    const conns = [];
    let refused;
    for (let i = 0; i < 20 && !refused; i++) {
      const ws = new WebSocket(wsUrl, ['foxglove.websocket.v1']);
      const c = { ws, closed: null };
      c.closedP = new Promise((r) => ws.on('close', (code, reason) => { c.closed = { code, reason: reason.toString() }; r(); }));
      // Either it is served (its advertise comes) or it is closed.
      await new Promise((r) => {
        ws.on('message', r);
        c.closedP.then(r);
      });
      conns.push(c);
      if (c.closed) refused = c.closed;
    }
    assert.ok(refused, 'no connection was refused');
    assert.equal(refused.code, 1013);
    assert.match(refused.reason, /too many Foxglove viewers/);
    for (const c of conns) c.ws.close();
    await Promise.all(conns.map((c) => c.closedP));
    // Room again once they left: a new viewer is served.
    await until(async () => {
      const c = await raw(wsUrl);
      await until(() => c.frames.length > 0 || c.ws.readyState !== WebSocket.OPEN, 10000, 'no answer');
      const served = c.frames.some((f) => f.op === 'serverInfo');
      c.ws.close();
      return served;
    }, 20000, 'no room after the viewers left');
  });

  test('hostile input gets status errors, never a crash; publishing elsewhere is refused', async () => {
    const c = await raw(wsUrl);
    assert.ok(c.opened);
    await until(() => c.frames.some((f) => f.op === 'advertise'), 10000, 'no advertise');
    c.ws.send('{not json');
    c.ws.send(JSON.stringify({ op: 'getParameters', parameterNames: [] }));
    c.ws.send(JSON.stringify({ op: 'subscribe', subscriptions: [{ id: 1, channelId: 99999 }] }));
    c.ws.send(JSON.stringify({ op: 'advertise', channels: [{ id: 1, topic: 'vision', encoding: 'json', schemaName: 'x' }] }));
    c.ws.send(Buffer.from([1, 1, 0, 0, 0, 0x7b, 0x7d]));
    c.ws.send(Buffer.from([0xff, 0, 1]));
    c.ws.send(JSON.stringify({ op: 'advertise', channels: [{ id: 2, topic: '/colony/override', encoding: 'json', schemaName: 'x' }] }));
    c.ws.send(Buffer.concat([Buffer.from([1, 2, 0, 0, 0]), Buffer.from('{"t":"publish","text":"@ <radio> 99\\ncmd id 0 forward 1 turn 0\\n"}')]));
    const errors = () => c.frames.filter((f) => f.op === 'status' && f.level === 2);
    await until(() => errors().length >= 7, 10000, `status errors: ${JSON.stringify(errors())}`);
    assert.ok(errors().some((e) => /only the operator's override/.test(e.message)));
    // A frame larger than the endpoint reads closes that connection alone.
    const closed = new Promise((r) => c.ws.on('close', r));
    c.ws.send('x'.repeat(200000));
    await Promise.race([closed, sleep(10000).then(() => { throw new Error('a huge frame did not close the connection'); })]);
    // The endpoint and the demo carry on: the library client still gets vision.
    const sub = client.subscribe(channels.get('vision').id);
    await until(() => (bySub.get(sub) || []).length > 0, 20000, 'no vision after the hostile client');
    assert.equal(demo.child.exitCode, null);
  });
});

describe('the Foxglove WebSocket during a live game', { concurrency: false, timeout: 120000 }, () => {
  let game;
  let client;
  const channels = new Map();
  const last = new Map(); // topic -> newest message
  const subs = new Map(); // subscription id -> topic

  before(async () => {
    const hubPort = await freeUdpPort();
    game = new ColonyProcess('foxglove-game', [
      'game', 'ctf', '--player', 'none', '--hub-bind', `127.0.0.1:${hubPort}`, '--monitor-bind', '127.0.0.1:0',
    ]);
    const [, host, token] = await game.waitFor(/http:\/\/(127\.0\.0\.1:\d+)\/\S*token=([0-9a-f]{32})/);
    client = new FoxgloveClient({ ws: new WebSocket(`ws://${host}/foxglove?token=${token}`, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
    client.on('advertise', (list) => {
      for (const c of list) {
        channels.set(c.topic, c);
        if (c.topic.startsWith('/colony/battlefield')) subs.set(client.subscribe(c.id), c.topic);
      }
    });
    client.on('message', ({ subscriptionId, data }) => {
      last.set(subs.get(subscriptionId), JSON.parse(decoder.decode(data)));
    });
  });

  after(async () => {
    if (client) client.close();
    if (game) await game.stop();
  });

  test('the battlefield comes as scene entities: terrain, every robot with its heading, the flags', async () => {
    const scene = await until(() => last.get('/colony/battlefield'), 60000, 'no battlefield scene');
    const terrain = await until(() => last.get('/colony/battlefield/terrain'), 60000, 'no terrain');
    const byId = Object.fromEntries(scene.entities.map((e) => [e.id, e]));
    assert.equal(byId.robots.frame_id, 'battlefield');
    // Two teams of six by default (--red and --blue).
    assert.equal(byId.robots.cylinders.length, 12);
    assert.equal(byId.robots.arrows.length, 12);
    assert.equal(byId.flags.spheres.length, 2);
    assert.ok(terrain.entities[0].cubes.length > 0);
    assert.ok(channels.has('game.state'), [...channels.keys()].join(' '));
  });
});

test('the monitor refuses --foxglove-origin with --no-token', () => {
  const r = spawnSync(colonyBin(), ['monitor', '--no-token', '--foxglove-origin', 'https://app.foxglove.dev',
    '--bind', '127.0.0.1:0'], { encoding: 'utf8', timeout: 20000 });
  assert.notEqual(r.status, 0, r.stdout);
  assert.match(r.stderr, /--foxglove-origin with --no-token/);
});
