// The pages' shared module (crates/monitor/web/common.js) on its own, under
// node with stand-ins for the browser's canvas and WebSocket: escaping, the
// world <-> screen transform both pages draw and click through, and the
// socket's reconnect backoff. No browser, no colony process.
import assert from 'node:assert/strict';
import path from 'node:path';
import { afterEach, beforeEach, describe, mock, test } from 'node:test';
import { pathToFileURL } from 'node:url';
import { ROOT } from './lib.mjs';

const common = await import(pathToFileURL(path.join(ROOT, 'crates', 'monitor', 'web', 'common.js')).href);
const { Transform, esc, serverLink, showBanners, tenth, withToken, RETRY_MAX_MS, RETRY_MIN_MS } = common;

/** A canvas of `w` x `h` device pixels, its CSS box at (left, top). */
function fakeCanvas(w, h, left = 0, top = 0, dpr = 1) {
  return {
    width: w,
    height: h,
    getBoundingClientRect: () => ({ left, top, width: w / dpr, height: h / dpr }),
  };
}

const near = (a, b, what) => assert.ok(Math.abs(a - b) < 1e-9, `${what}: ${a} vs ${b}`);

describe('the pages\' shared module', () => {
  afterEach(() => { delete globalThis.devicePixelRatio; });

  test('text from the network cannot open a tag or leave an attribute', () => {
    assert.equal(esc('<b class="x">Tom\'s & co</b>'), '&lt;b class=&quot;x&quot;&gt;Tom&#39;s &amp; co&lt;/b&gt;');
    assert.equal(esc('plain 12.5'), 'plain 12.5');
    assert.equal(esc(42), '42');
    assert.equal(esc(null), 'null');
  });

  test('coordinates are sent to the millimetre', () => {
    assert.equal(tenth(12.345), 12.3);
    assert.equal(tenth(-0.06), -0.1);
    assert.equal(tenth(7), 7);
  });

  test('the panned and zoomed view puts its centre mid-canvas, y up, and a click maps back to the point drawn', () => {
    for (const dpr of [1, 2]) {
      globalThis.devicePixelRatio = dpr;
      const canvas = fakeCanvas(800 * dpr, 600 * dpr, 30, 70, dpr);
      const t = Transform.centred(canvas, 10, -20, 3);
      near(t.k, 3 * dpr, 'device pixels per cm');
      const mid = t.toCanvas(10, -20);
      near(mid.x, 400, 'the view centre, x');
      near(mid.y, 300, 'the view centre, y');
      const up = t.toCanvas(10, -10);
      near(up.y, 300 - 30, 'y grows upwards on screen');
      for (const [x, y] of [[0, 0], [123.4, -56.7], [-500, 499]]) {
        const c = t.toClient(x, y);
        const back = t.fromClient(c.x, c.y);
        near(back.x, x, `x round trip at dpr ${dpr}`);
        near(back.y, y, `y round trip at dpr ${dpr}`);
      }
    }
  });

  test('the fitted view shows the whole extent, centred, inside its padding', () => {
    globalThis.devicePixelRatio = 2;
    const canvas = fakeCanvas(1000, 500, 0, 0, 2);
    const extent = { x0: 0, y0: 0, w: 1280, h: 960 }; // the ctf map, 64 x 48 cells of 20 cm
    const t = Transform.fitted(canvas, extent, 10);
    const bl = t.toCanvas(0, 0);
    const tr = t.toCanvas(1280, 960);
    // CSS pixels: the canvas is 500 x 250; the taller side touches the padding.
    near(tr.y, 10, 'the top edge sits on the padding');
    near(bl.y, 240, 'the bottom edge sits on the padding');
    near((bl.x + tr.x) / 2, 250, 'centred across');
    assert.ok(bl.x >= 10 && tr.x <= 490, `inside the padding across (${bl.x}, ${tr.x})`);
    const back = t.fromClient(t.toClient(640, 480).x, t.toClient(640, 480).y);
    near(back.x, 640, 'x round trip');
    near(back.y, 480, 'y round trip');
  });

  test('banners are rebuilt only when their text changes', () => {
    globalThis.document = { createElement: () => ({}) };
    const box = { dataset: {}, children: [], replaceChildren(...c) { this.children = c; } };
    const notes = [{ cls: 'stale-banner hub', id: 'banner-hub', text: 'hub stale since 12:00:00' }];
    assert.equal(showBanners(box, notes), true);
    assert.deepEqual(box.children.map((d) => [d.className, d.id, d.textContent]),
      [['stale-banner hub', 'banner-hub', 'hub stale since 12:00:00']]);
    assert.equal(showBanners(box, notes), false, 'same text: left alone');
    assert.equal(showBanners(box, []), true);
    assert.deepEqual(box.children, []);
    delete globalThis.document;
  });
});

describe('the link to the monitor server', () => {
  let sockets;

  beforeEach(() => {
    sockets = [];
    mock.timers.enable({ apis: ['setTimeout'] });
    globalThis.location = { protocol: 'http:', host: '127.0.0.1:8080' };
    globalThis.WebSocket = class {
      static OPEN = 1;
      constructor(url) { this.url = url; this.readyState = 0; this.sent = []; sockets.push(this); }
      send(text) { this.sent.push(text); }
      open() { this.readyState = 1; this.onopen(); }
      close() { this.readyState = 3; this.onclose(); }
    };
  });

  afterEach(() => {
    mock.timers.reset();
    delete globalThis.WebSocket;
    delete globalThis.location;
  });

  test('a lost server is tried again after 0.5, 1, 2, 4, 4 s, and from 0.5 s once it answered', () => {
    const events = [];
    const link = serverLink('/ws?view=game', {
      onOpen: () => events.push('open'),
      onMessage: () => {},
      onClose: (was) => events.push(`close ${was}`),
    });
    assert.equal(sockets.length, 1);
    assert.equal(sockets[0].url, 'ws://127.0.0.1:8080/ws?view=game');
    const waits = [];
    for (let i = 0; i < 5; i++) {
      sockets.at(-1).close();
      const n = sockets.length;
      let waited = 0;
      while (sockets.length === n) { mock.timers.tick(100); waited += 100; }
      waits.push(waited);
    }
    assert.deepEqual(waits, [RETRY_MIN_MS, 1000, 2000, RETRY_MAX_MS, RETRY_MAX_MS]);
    sockets.at(-1).open();
    assert.equal(link.connected, true);
    sockets.at(-1).close();
    assert.equal(link.connected, false);
    mock.timers.tick(RETRY_MIN_MS);
    assert.equal(sockets.length, 7, 'back to the shortest wait after a connection');
    assert.deepEqual(events.slice(-3), ['close false', 'open', 'close true']);
  });

  test('only JSON objects reach the page, and nothing is sent while the link is down', () => {
    const got = [];
    const link = serverLink('/ws', { onMessage: (m) => got.push(m) });
    assert.equal(link.send({ t: 'take_all' }), false);
    const s = sockets[0];
    s.open();
    for (const data of ['{"t":"world","step":3}', 'not json', 'null', '7', '{"t":"hub"}']) s.onmessage({ data });
    assert.deepEqual(got, [{ t: 'world', step: 3 }, { t: 'hub' }]);
    assert.equal(link.send({ t: 'take_all' }), true);
    assert.deepEqual(s.sent, ['{"t":"take_all"}']);
  });

  test('the token the page was opened with goes on its WebSocket', () => {
    globalThis.location = { protocol: 'http:', host: '127.0.0.1:8080', search: '?team=red&token=0a1b' };
    serverLink('/ws?view=game', { onMessage: () => {} });
    serverLink('/ws', { onMessage: () => {} });
    assert.equal(sockets[0].url, 'ws://127.0.0.1:8080/ws?view=game&token=0a1b');
    assert.equal(sockets[1].url, 'ws://127.0.0.1:8080/ws?token=0a1b');
    assert.equal(withToken('/'), '/?token=0a1b');
  });
});
