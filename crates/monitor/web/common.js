// colony monitor: what the monitor page (app.js) and the game page (game.js)
// share. Plain JavaScript, no library; an ES module, served as /common.js.
//
// The monitor server speaks JSON over one WebSocket per tab; both pages draw
// a world in centimetres with y up on a canvas; both show banners, a
// connection chip and messages the same way. Each rule is written here once.

/** The element with this id. */
export const $ = (id) => document.getElementById(id);

// ---- text ---------------------------------------------------------------------

const ENTITIES = { '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' };

/**
 * `v` as text safe inside HTML, both between tags and inside a quoted
 * attribute: packets, channel names and robot reasons come from the network.
 */
export const esc = (v) => String(v).replace(/[&<>"']/g, (c) => ENTITIES[c]);

/** A coordinate as the pages send it: to the millimetre (0.1 cm). */
export const tenth = (v) => Math.round(v * 10) / 10;

// ---- the connection -------------------------------------------------------------

/** The first wait before reconnecting, in ms; it doubles up to RETRY_MAX_MS. */
export const RETRY_MIN_MS = 500;
/** The longest wait between two attempts to reach the server again, in ms. */
export const RETRY_MAX_MS = 4000;

/**
 * `path` with the monitor's token added, as the page was given it (`?token=...`
 * in its own address, as the monitor prints it): the server refuses the
 * WebSocket and the pages without it, so another site cannot use them.
 */
export function withToken(path) {
  const token = new URLSearchParams(location.search ?? '').get('token');
  if (!token) return path;
  return `${path}${path.includes('?') ? '&' : '?'}token=${encodeURIComponent(token)}`;
}

/**
 * One WebSocket to the monitor server at `path` (e.g. `/ws?view=game`), opened
 * again after every close with a doubling backoff (RETRY_MIN_MS to
 * RETRY_MAX_MS), so a monitor that comes back finds its tabs back (a new
 * monitor has a new token: its tabs are refused until opened at its address).
 *
 * `onMessage(msg)` gets each text message that parses as a JSON object (any
 * other text is dropped: the page has nothing to do with it), `onBinary(buf)`
 * each binary message as an ArrayBuffer (dropped without it); `onOpen()` and
 * `onClose()` report the link going up and down. Returns
 * `{ send(obj) -> bool, connected }`: `send` is false when the link is down.
 */
export function serverLink(path, {
  onOpen = () => {}, onMessage, onBinary = null, onClose = () => {},
}) {
  let socket = null;
  let retryMs = RETRY_MIN_MS;
  const link = {
    connected: false,
    send(obj) {
      if (socket && socket.readyState === WebSocket.OPEN) {
        socket.send(JSON.stringify(obj));
        return true;
      }
      return false;
    },
    /** Reconnects at another address (the game page playing another team). */
    setPath(p) {
      if (p === path) return;
      path = p;
      retryMs = 0; // at once: this is no lost server
      if (socket) socket.close();
    },
  };
  function connect() {
    const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
    socket = new WebSocket(`${proto}//${location.host}${withToken(path)}`);
    socket.onopen = () => {
      link.connected = true;
      retryMs = RETRY_MIN_MS;
      onOpen();
    };
    // Binary messages (the world's bodies) come as ArrayBuffers, for typed arrays over them.
    socket.binaryType = 'arraybuffer';
    socket.onmessage = (ev) => {
      if (ev.data instanceof ArrayBuffer) {
        if (onBinary) onBinary(ev.data);
        return;
      }
      let msg;
      try { msg = JSON.parse(ev.data); } catch (e) { return; }
      if (msg && typeof msg === 'object') onMessage(msg);
    };
    const mine = socket;
    socket.onclose = () => {
      if (socket !== mine) return;
      const was = link.connected;
      link.connected = false;
      onClose(was);
      setTimeout(connect, retryMs);
      retryMs = Math.max(RETRY_MIN_MS, Math.min(retryMs * 2, RETRY_MAX_MS));
    };
    socket.onerror = () => {};
  }
  connect();
  return link;
}

// ---- the view: world centimetres (y up) to canvas pixels ----------------------------

/** Canvas device pixels per CSS pixel (globalThis is the window in a page). */
export const pixelRatio = () => globalThis.devicePixelRatio || 1;

/**
 * Sizes `canvas`'s backing store to its CSS box in device pixels, so drawings
 * stay sharp on any screen; true when the size changed (redraw then).
 */
export function fitBacking(canvas) {
  const dpr = pixelRatio();
  const r = canvas.getBoundingClientRect();
  const w = Math.max(1, Math.round(r.width * dpr));
  const h = Math.max(1, Math.round(r.height * dpr));
  if (canvas.width === w && canvas.height === h) return false;
  canvas.width = w;
  canvas.height = h;
  return true;
}

/**
 * A world-to-canvas mapping: world (x, y) in cm, y up, lands on canvas device
 * pixel (ox + x k, oy - y k). Both pages draw through one; clicks come back
 * through `fromClient`.
 */
export class Transform {
  constructor(canvas, k, ox, oy) {
    /** The canvas drawn on. */
    this.canvas = canvas;
    /** Device pixels per cm. */
    this.k = k;
    /** Where world x = 0 falls, in device pixels. */
    this.ox = ox;
    /** Where world y = 0 falls, in device pixels. */
    this.oy = oy;
    /** Device pixels per CSS pixel. */
    this.dpr = pixelRatio();
  }

  /**
   * The panned and zoomed view: world point (cx, cy) at the canvas's centre,
   * `scale` CSS pixels per cm.
   */
  static centred(canvas, cx, cy, scale) {
    const k = scale * pixelRatio();
    return new Transform(canvas, k, canvas.width / 2 - cx * k, canvas.height / 2 + cy * k);
  }

  /**
   * The whole of `extent` ({x0, y0, w, h} in cm) as large as fits, centred,
   * `padCss` CSS pixels from the canvas's edges.
   */
  static fitted(canvas, extent, padCss) {
    const pad = padCss * pixelRatio();
    const k = Math.max(1e-6, Math.min((canvas.width - 2 * pad) / extent.w, (canvas.height - 2 * pad) / extent.h));
    const ox = (canvas.width - extent.w * k) / 2 - extent.x0 * k;
    const oy = (canvas.height + extent.h * k) / 2 + extent.y0 * k;
    return new Transform(canvas, k, ox, oy);
  }

  /** World cm to canvas CSS pixels, from the canvas's top-left corner. */
  toCanvas(x, y) {
    return { x: (this.ox + x * this.k) / this.dpr, y: (this.oy - y * this.k) / this.dpr };
  }

  /** World cm to page client pixels: where a mouse click on (x, y) lands. */
  toClient(x, y) {
    const p = this.toCanvas(x, y);
    const r = this.canvas.getBoundingClientRect();
    return { x: r.left + p.x, y: r.top + p.y };
  }

  /** Page client pixels (a mouse event's clientX, clientY) to world cm. */
  fromClient(cx, cy) {
    const r = this.canvas.getBoundingClientRect();
    const px = (cx - r.left) * this.dpr;
    const py = (cy - r.top) * this.dpr;
    return { x: (px - this.ox) / this.k, y: (this.oy - py) / this.k };
  }
}

/**
 * Text on a canvas in the pages' bold face, `px` device pixels high, in the
 * canvas's current transform; `halo` outlines it dark so it reads on any
 * ground.
 */
export function drawText(ctx, text, x, y, { fill, px, align = 'left', halo = false }) {
  ctx.font = `600 ${px}px system-ui, sans-serif`;
  ctx.textAlign = align;
  if (halo) {
    ctx.lineWidth = 3;
    ctx.strokeStyle = 'rgba(0,0,0,0.65)';
    ctx.strokeText(text, x, y);
  }
  ctx.fillStyle = fill;
  ctx.fillText(text, x, y);
}

// ---- the page's chrome ------------------------------------------------------------

/**
 * Shows `notes` ([{ cls, id?, text }]) as the banners in `box`, rebuilt only
 * when their text changed (they are refreshed twice a second); true when it did.
 */
export function showBanners(box, notes) {
  const key = notes.map((n) => n.text).join('|');
  if (box.dataset.key === key) return false;
  box.dataset.key = key;
  box.replaceChildren(...notes.map(({ cls, id, text }) => {
    const d = document.createElement('div');
    d.className = cls;
    if (id) d.id = id;
    d.textContent = text;
    return d;
  }));
  return true;
}

/** The header's connection chip: `text`, green when `ok`, red otherwise. */
export function showChip(chip, text, ok) {
  chip.textContent = text;
  // null: neither good nor bad news (a pre-match, a run that ended), so not red.
  chip.className = ok === null ? 'chip' : `chip ${ok ? 'ok' : 'bad'}`;
}

/** A one-line answer under a control: green when `ok`, red otherwise. */
export function showMessage(el, text, ok) {
  el.textContent = text;
  el.className = `msg ${ok ? 'ok' : 'err'}`;
}
