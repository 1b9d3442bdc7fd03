// Headless Chromium on evermap-viewer's page for bench/viewer_latency.sh: loads the page, waits
// --duration-s, then reads the page's window.evermapStats (viewer/web/viewer.js) and prints
// figures. Driven over the DevTools protocol on a pipe (tests/integration/chromium_cdp.mjs).
//   node viewer_latency.mjs --chromium PATH --url URL --duration-s S [--label TEXT] [--screenshot PNG]
// Prints one line of figures:
//   - load: navigation start to the first frame with a map drawn (needs a map on the stream);
//   - per map (`utime` = its publish time, wall clock, bench/viewer-graph-pub): latency from
//     publish to the frame after the one that drew it (the drawn frame was handed over by then),
//     median and p90, and its parts: viewer (LCM + JSON, to `built_ms`), transfer (WebSocket),
//     parse (JSON.parse), scene (three.js geometry), wait (for the next animation frame; the page
//     draws at most 4 frames a second with software WebGL), render;
//   - the update rate: maps drawn per second, and maps received but superseded before drawing.
// No assertion on time: exit status 0 unless the page failed or drew no map.
import fs from 'node:fs';

import { launchChromium, openPage, parseOptions, sleep } from '../tests/integration/chromium_cdp.mjs';

const opt = parseOptions('viewer_latency', { durationS: 30, label: '' }, ['chromium', 'url']);
const { send, errors, finish } = launchChromium('viewer_latency', opt.chromium);

function quantile(values, q) {
  if (values.length === 0) return NaN;
  const v = [...values].sort((a, b) => a - b);
  const pos = q * (v.length - 1), lo = Math.floor(pos), hi = Math.ceil(pos);
  return v[lo] + (v[hi] - v[lo]) * (pos - lo);
}
const fmt = (values) => `${quantile(values, 0.5).toFixed(0)}/${quantile(values, 0.9).toFixed(0)}`;

try {
  const sessionId = await openPage(send, ['Runtime', 'Page']);
  await send('Page.navigate', { url: opt.url }, sessionId);
  await sleep(Number(opt.durationS) * 1000);
  const r = await send('Runtime.evaluate', {
    returnByValue: true,
    expression: `(() => { const s = window.evermapStats || {};
      return { graphs: s.graphs || [], firstMapMs: s.firstMapMs, frames: s.frames, errors: (window.evermapErrors || []).join(' | '),
               image: !document.getElementById('image').hidden }; })()`,
  }, sessionId);
  const s = r.result.value;
  if (opt.screenshot) {
    const shot = await send('Page.captureScreenshot', { format: 'png' }, sessionId);
    fs.writeFileSync(opt.screenshot, Buffer.from(shot.data, 'base64'));
  }
  // The first map is left out of the latency: it waited for the page to load.
  const all = s.graphs.filter((g) => g.utime > 0);
  const drawn = all.slice(1).filter((g) => g.next_frame_ms !== undefined);
  const col = (f) => drawn.map(f);
  const pub = (g) => g.utime / 1000;
  const span = drawn.length > 1 ? (drawn[drawn.length - 1].next_frame_ms - drawn[0].next_frame_ms) / 1000 : NaN;
  const nodes = all.length ? all[all.length - 1].nodes : 0;
  const line = `viewer_latency${opt.label ? ' ' + opt.label : ''}: nodes ${nodes}, text ${all.length ? (all[all.length - 1].bytes / 1e6).toFixed(1) : 0} MB; ` +
    `load (first map drawn) ${s.firstMapMs === null ? '-' : s.firstMapMs.toFixed(0)} ms; ` +
    `maps received ${all.length}, drawn ${drawn.length + (all[0]?.next_frame_ms !== undefined ? 1 : 0)}, ` +
    `drawn per s ${(drawn.length > 1 ? (drawn.length - 1) / span : 0).toFixed(2)}; ` +
    `latency publish->pixels median/p90 ${fmt(col((g) => g.next_frame_ms - pub(g)))} ms ` +
    `[viewer ${fmt(col((g) => g.built_ms - pub(g)))}, transfer ${fmt(col((g) => g.received_ms - g.built_ms))}, ` +
    `parse ${fmt(col((g) => g.parse_ms))}, scene ${fmt(col((g) => g.scene_ms))}, ` +
    `wait ${fmt(col((g) => g.render_start_ms - g.received_ms - g.parse_ms - g.scene_ms))}, ` +
    `render ${fmt(col((g) => g.render_end_ms - g.render_start_ms))}, ` +
    `to next frame ${fmt(col((g) => g.next_frame_ms - g.render_end_ms))}]; frames ${s.frames}; ` +
    `camera image ${s.image ? 'shown' : 'none'}`;
  if (opt.json) fs.writeFileSync(opt.json, JSON.stringify(s));
  if (errors.length > 0 || s.errors) await finish(1, `viewer_latency: FAIL: ${[...errors, s.errors].join(' || ')}; ${line}`);
  if (all.length === 0) await finish(1, `viewer_latency: FAIL: no map reached the page; ${line}`);
  await finish(0, line);
} catch (e) {
  await finish(1, `viewer_latency: FAIL: ${e.message}`);
}
