// Drives headless Chromium (chromium_cdp.mjs) for tests/integration/map_export_rendered.sh:
//   node viewer_plan.mjs --chromium PATH --url URL --floor N --occupied K --screenshot PNG
//                        [--timeout-s S]
// Loads the page of `evermap-viewer --store MAP --plans DIR` and polls it until it shows
// floor N's plan with K occupied cells (the page's data-plan-floor / data-plan-occupied, set
// once the plan is in the scene), has drawn a frame since, and had no script error. Saves a
// screenshot; prints one line; exit status 0 on success.
import fs from 'node:fs';

import { launchChromium, openPage, parseOptions, sleep } from './chromium_cdp.mjs';

const opt = parseOptions('viewer_plan', { timeoutS: 60 }, ['chromium', 'url', 'floor', 'occupied', 'screenshot']);
const { send, errors, finish } = launchChromium('viewer_plan', opt.chromium);

try {
  const sessionId = await openPage(send);
  const evaluate = async (expression) =>
    (await send('Runtime.evaluate', { returnByValue: true, expression }, sessionId)).result.value;
  await send('Page.navigate', { url: opt.url }, sessionId);
  const start = Date.now();
  let page = null, framesAtPlan = null;
  while (Date.now() - start < Number(opt.timeoutS) * 1000) {
    await sleep(250);
    const value = await evaluate(`(() => { const d = document.documentElement.dataset;
        return { floor: d.planFloor, occupied: d.planOccupied, frames: Number(d.frames || 0),
                 errors: Number(d.errors || 0), pageErrors: (window.evermapErrors || []).join(' | '),
                 line: document.getElementById('plan')?.textContent,
                 meshes: window.evermapScene?.plan?.group?.children?.length ?? 0 }; })()`);
    if (value === undefined) continue;  // between documents
    page = value;
    if (page.errors > 0) break;
    const shown = page.floor === String(opt.floor) && page.occupied === String(opt.occupied) && page.meshes === 1;
    if (shown && framesAtPlan === null) framesAtPlan = page.frames;
    if (shown && page.frames > framesAtPlan) break;
  }
  await sleep(500);
  const shot = await send('Page.captureScreenshot', { format: 'png' }, sessionId);
  fs.writeFileSync(opt.screenshot, Buffer.from(shot.data, 'base64'));
  const figures = `page shows the plan of floor ${page?.floor} with ${page?.occupied} occupied cells ` +
    `(expected floor ${opt.floor}, ${opt.occupied}), ${page?.meshes} plan mesh, ${page?.frames} frames: "${page?.line}"; ` +
    `screenshot ${opt.screenshot}`;
  if (page?.errors > 0) errors.push('page: ' + (page.pageErrors || 'data-errors > 0'));
  if (errors.length > 0) await finish(1, `viewer_plan: FAIL: script errors: ${errors.join(' || ')}; ${figures}`);
  if (!(page && page.floor === String(opt.floor) && page.occupied === String(opt.occupied) && page.meshes === 1 &&
        framesAtPlan !== null && page.frames > framesAtPlan))
    await finish(1, `viewer_plan: FAIL: ${figures}`);
  await finish(0, `viewer_plan: ${figures}`);
} catch (e) {
  await finish(1, `viewer_plan: FAIL: ${e.message}`);
}
