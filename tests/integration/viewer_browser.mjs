// Drives headless Chromium (chromium_cdp.mjs) for tests/integration/viewer_browser.sh:
//   node viewer_browser.mjs --chromium PATH --url URL --expect-file FILE --screenshot PNG [--timeout-s S]
//                           [--seek FRACTION]
// Loads the page, then polls it until FILE exists and holds a node count N and the page shows
// N nodes (#count-nodes), has drawn that graph and at least one 3-D frame. Then it clicks, with
// the mouse, the drawn node farthest from any other on the screen and waits for the page to
// show that node's details (#node-details). With --seek (a page
// of `evermap-viewer --log`), it then moves the time slider to FRACTION of the log and waits
// until the page shows fewer nodes than N and its slider is there, and sets the page's speed
// control to 5 and waits until the viewer says it plays at 5. Any script error
// (an exception, console.error, an error logged by the browser, the page's own data-errors)
// fails. Saves a screenshot. Prints one line of figures; exit status 0 on success.
import fs from 'node:fs';

import { launchChromium, openPage, parseOptions, sleep } from './chromium_cdp.mjs';

const opt = parseOptions('viewer_browser', { timeoutS: 120 }, ['chromium', 'url', 'expectFile', 'screenshot']);
const { send, errors, finish } = launchChromium('viewer_browser', opt.chromium);

try {
  const sessionId = await openPage(send);
  // The value of `expression` in the page (undefined while the page is between documents).
  const evaluate = async (expression) =>
    (await send('Runtime.evaluate', { returnByValue: true, expression }, sessionId)).result.value;
  // Evaluates `expression` every `periodMs` until `done(value)` or `timeoutMs`: the last value.
  const waitFor = async (expression, done, timeoutMs, periodMs) => {
    const start = Date.now();
    let value = null;
    while (Date.now() - start < timeoutMs) {
      await sleep(periodMs);
      value = await evaluate(expression);
      if (done(value)) break;
    }
    return value;
  };
  // Sets the page's control `id` to `value` as a user would (a change event).
  const setControl = (id, value) => evaluate(`(() => { const s = document.getElementById('${id}'); s.value = '${value}';
                                                      s.dispatchEvent(new Event('change')); })()`);
  await send('Page.navigate', { url: opt.url }, sessionId);
  const start = Date.now();
  let page = null, expected = null;
  while (Date.now() - start < Number(opt.timeoutS) * 1000) {
    await sleep(250);
    if (expected === null && fs.existsSync(opt.expectFile)) {
      const text = fs.readFileSync(opt.expectFile, 'utf8').trim();
      if (text !== '') expected = text;
    }
    const value = await evaluate(`(() => { const d = document.documentElement.dataset, n = performance.getEntriesByType('navigation')[0];
        return { nodes: document.getElementById('count-nodes')?.textContent, drawn: d.graphNodes, frames: Number(d.frames || 0),
                 errors: Number(d.errors || 0), pageErrors: (window.evermapErrors || []).join(' | '),
                 connection: document.getElementById('connection')?.textContent,
                 loadMs: n ? Math.round(n.loadEventEnd) : -1, latency: document.getElementById('latency')?.textContent }; })()`);
    // Undefined while the page is between documents (the evaluation ran in a context the
    // navigation destroyed): polled again.
    if (value === undefined) continue;
    page = value;
    if (page.errors > 0) break;
    if (expected !== null && page.nodes === expected && page.drawn === expected && page.frames > 0) break;
  }
  let clickFigures = '';
  if (expected !== null && page.nodes === expected && page.errors === 0) {
    // The node to click: on the canvas, the one with the most room around it (so that the
    // nearest node to the pixel is that one, whatever the camera).
    const target = await evaluate(`(() => { const s = window.evermapScene; if (!s || !s.graph) return null;
        const rect = s.renderer.domElement.getBoundingClientRect(), g = s.graph, n = Math.min(g.nodes.id.length, 2000);
        const pts = [];
        for (let i = 0; i < n; ++i) { const p = s.screenOfIndex(i);
          if (p && p.x > rect.left + 10 && p.x < rect.right - 10 && p.y > rect.top + 10 && p.y < rect.bottom - 10) pts.push([i, p]); }
        let best = null, room = -1;
        for (const [i, p] of pts) { let d = Infinity;
          for (const [j, q] of pts) if (j !== i) d = Math.min(d, Math.hypot(p.x - q.x, p.y - q.y));
          if (d > room) { room = d; best = { id: g.nodes.id[i], x: p.x, y: p.y, room: d }; } }
        return best; })()`);
    if (!target) {
      errors.push('no node of the map is drawn on the canvas to click');
    } else {
      for (const type of ['mouseMoved', 'mousePressed', 'mouseReleased'])
        await send('Input.dispatchMouseEvent', { type, x: target.x, y: target.y, button: 'left', buttons: type === 'mousePressed' ? 1 : 0, clickCount: 1 }, sessionId);
      const shown = await waitFor(`(() => { const d = document.getElementById('node-details');
            return { node: d.dataset.node, hidden: d.hidden, text: d.textContent }; })()`,
        (v) => v?.node === String(target.id), 10000, 100);
      clickFigures = `; clicked node ${target.id} (${Math.round(target.room)} px from the next): details ${shown && !shown.hidden ? 'shown' : 'not shown'}`;
      if (!(shown && !shown.hidden && shown.node === String(target.id) && shown.text.includes('node ' + target.id + ':')))
        errors.push(`a click on node ${target.id} at (${Math.round(target.x)}, ${Math.round(target.y)}) did not show its details: ${JSON.stringify(shown)}`);
    }
  }
  let seekFigures = '';
  if (opt.seek !== undefined && expected !== null && page.nodes === expected && page.errors === 0) {
    const value = Math.round(Number(opt.seek) * 1000);
    await setControl('log-slider', value);
    const after = await waitFor(`({ nodes: Number(document.getElementById('count-nodes').textContent),
                        slider: Number(document.getElementById('log-slider').value),
                        errors: Number(document.documentElement.dataset.errors || 0) })`,
      (v) => v && (v.errors > 0 || (v.nodes < Number(expected) && Math.abs(v.slider - value) <= 20)), 30000, 250);
    seekFigures = `; after the seek to ${opt.seek}: ${after?.nodes} nodes, slider ${after?.slider}/1000`;
    if (!(after && after.nodes < Number(expected) && Math.abs(after.slider - value) <= 20))
      errors.push(`the seek to ${opt.seek} did not take the page back${seekFigures}`);
    // The speed control: the viewer must play at the speed chosen on the page.
    await setControl('log-speed', 5);
    const speed = await waitFor('window.evermapLog?.speed', (v) => v === 5, 10000, 200);
    seekFigures += `; speed set to 5 on the page, the viewer plays at ${speed}`;
    if (speed !== 5) errors.push(`the page's speed control did not reach the viewer (it plays at ${speed})`);
    page.errors = after ? after.errors : page.errors;
  }
  await sleep(500);  // one more frame of the final map for the screenshot
  const shot = await send('Page.captureScreenshot', { format: 'png' }, sessionId);
  fs.writeFileSync(opt.screenshot, Buffer.from(shot.data, 'base64'));
  const figures = `page shows ${page?.nodes} nodes (expected ${expected}), drawn ${page?.drawn}, ${page?.frames} frames, ` +
    `${page?.connection}, load ${page?.loadMs} ms, map latency ${page?.latency}${clickFigures}${seekFigures}; screenshot ${opt.screenshot}`;
  if (page?.errors > 0) errors.push('page: ' + (page.pageErrors || 'data-errors > 0'));
  if (errors.length > 0) await finish(1, `viewer_browser: FAIL: script errors: ${errors.join(' || ')}; ${figures}`);
  if (expected === null) await finish(1, `viewer_browser: FAIL: no node count to expect in ${opt.expectFile}; ${figures}`);
  if (page.nodes !== expected || page.drawn !== expected || !(page.frames > 0))
    await finish(1, `viewer_browser: FAIL: ${figures}`);
  await finish(0, `viewer_browser: ${figures}`);
} catch (e) {
  await finish(1, `viewer_browser: FAIL: ${e.message}`);
}
