// Headless Chromium on evermap-viewer's page for bench/viewer_latency.sh: loads the page, waits
// --duration-s, then reads the page's window.evermapStats (viewer/web/viewer.js) and prints
// figures. Driven over the DevTools protocol on a pipe, as tests/integration/viewer_browser.mjs.
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
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

const opt = { durationS: 30, label: '' };
for (let k = 2; k + 1 < process.argv.length; k += 2) {
  const name = process.argv[k].replace(/^--/, '').replace(/-(.)/g, (_, c) => c.toUpperCase());
  opt[name] = process.argv[k + 1];
}
for (const need of ['chromium', 'url'])
  if (!opt[need]) { console.error(`viewer_latency: --${need} is needed`); process.exit(2); }

const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'evermap-chromium-'));
const chrome = spawn(opt.chromium, [
  '--headless', '--no-sandbox', '--remote-debugging-pipe', '--no-first-run', '--no-default-browser-check',
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--window-size=1400,900',
  '--disable-background-timer-throttling', '--disable-renderer-backgrounding', '--disable-backgrounding-occluded-windows',
  `--user-data-dir=${profile}`, 'about:blank'], { stdio: ['ignore', 'ignore', 'pipe', 'pipe', 'pipe'] });
let chromeLog = '';
chrome.stdio[2].on('data', (d) => { chromeLog = (chromeLog + d).slice(-4000); });

const errors = [];
let nextId = 1;
const pending = new Map();
const send = (method, params = {}, sessionId) => new Promise((resolve, reject) => {
  const id = nextId++;
  pending.set(id, { resolve, reject, method });
  chrome.stdio[3].write(JSON.stringify({ id, method, params, ...(sessionId ? { sessionId } : {}) }) + '\0');
});
let buffer = '';
chrome.stdio[4].on('data', (chunk) => {
  buffer += chunk.toString('utf8');
  let end;
  while ((end = buffer.indexOf('\0')) >= 0) {
    const msg = JSON.parse(buffer.slice(0, end));
    buffer = buffer.slice(end + 1);
    if (msg.id !== undefined && pending.has(msg.id)) {
      const p = pending.get(msg.id);
      pending.delete(msg.id);
      if (msg.error) p.reject(new Error(`${p.method}: ${msg.error.message}`)); else p.resolve(msg.result);
    } else if (msg.method === 'Runtime.exceptionThrown') {
      const d = msg.params.exceptionDetails;
      errors.push('exception: ' + (d.exception?.description || d.text));
    }
  }
});

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
let finished = false;
async function finish(code, line) {
  if (finished) return;
  finished = true;
  console.log(line);
  try { await Promise.race([send('Browser.close'), sleep(3000)]); } catch (e) { /* closing anyway */ }
  chrome.kill('SIGKILL');
  fs.rmSync(profile, { recursive: true, force: true });
  process.exit(code);
}
chrome.on('exit', (code) => {
  if (!finished) finish(1, `viewer_latency: FAIL: chromium exited (${code}) early: ${chromeLog.split('\n').slice(-5).join(' | ')}`);
});

function quantile(values, q) {
  if (values.length === 0) return NaN;
  const v = [...values].sort((a, b) => a - b);
  const pos = q * (v.length - 1), lo = Math.floor(pos), hi = Math.ceil(pos);
  return v[lo] + (v[hi] - v[lo]) * (pos - lo);
}
const fmt = (values) => `${quantile(values, 0.5).toFixed(0)}/${quantile(values, 0.9).toFixed(0)}`;

try {
  const { targetId } = await send('Target.createTarget', { url: 'about:blank' });
  const { sessionId } = await send('Target.attachToTarget', { targetId, flatten: true });
  await send('Runtime.enable', {}, sessionId);
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
