// Headless Chromium driven over the DevTools protocol on a pipe (--remote-debugging-pipe: no
// port, no WebSocket client needed), shared by tests/integration/viewer_browser.mjs and
// bench/viewer_latency.mjs. Software WebGL (SwiftShader), timers not throttled in the background.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

// `--some-name VALUE` pairs into { someName: VALUE } over `defaults`; exits 2 naming the first
// of `required` that is missing.
export function parseOptions(tool, defaults, required, argv = process.argv) {
  const opt = { ...defaults };
  for (let k = 2; k + 1 < argv.length; k += 2) {
    const name = argv[k].replace(/^--/, '').replace(/-(.)/g, (_, c) => c.toUpperCase());
    opt[name] = argv[k + 1];
  }
  for (const need of required) {
    if (!opt[need]) {
      console.error(`${tool}: --${need.replace(/[A-Z]/g, (c) => '-' + c.toLowerCase())} is needed`);
      process.exit(2);
    }
  }
  return opt;
}

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Starts Chromium. `send(method, params, sessionId)` resolves with the result; `errors` collects
// the page's exceptions, console.error calls and browser errors (once Runtime / Log are
// enabled); `finish(code, line)` prints the line, closes Chromium, removes its profile and exits.
// Chromium exiting early finishes with status 1 and its last log lines.
export function launchChromium(tool, chromiumPath) {
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'evermap-chromium-'));
  const chrome = spawn(chromiumPath, [
    '--headless', '--no-sandbox', '--remote-debugging-pipe', '--no-first-run', '--no-default-browser-check',
    '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--window-size=1400,900',
    '--disable-background-timer-throttling', '--disable-renderer-backgrounding', '--disable-backgrounding-occluded-windows',
    `--user-data-dir=${profile}`, 'about:blank'], { detached: true, stdio: ['ignore', 'ignore', 'pipe', 'pipe', 'pipe'] });
  // Chromium and its helper processes form their own process group (detached): they are
  // stopped together, so none is left writing into the profile as it is removed.
  const killChromium = () => { try { process.kill(-chrome.pid, 'SIGKILL'); } catch (e) { /* gone already */ } };
  const chromeExited = new Promise((resolve) => chrome.on('exit', resolve));
  process.on('exit', killChromium);
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
      } else if (msg.method === 'Runtime.consoleAPICalled' && msg.params.type === 'error') {
        errors.push('console.error: ' + msg.params.args.map((a) => a.value ?? a.description).join(' '));
      } else if (msg.method === 'Log.entryAdded' && msg.params.entry.level === 'error') {
        errors.push('browser: ' + msg.params.entry.text + (msg.params.entry.url ? ' ' + msg.params.entry.url : ''));
      }
    }
  });

  let finished = false;
  async function finish(code, line) {
    if (finished) return;
    finished = true;
    console.log(line);
    try { await Promise.race([send('Browser.close'), sleep(3000)]); } catch (e) { /* closing anyway */ }
    killChromium();
    await Promise.race([chromeExited, sleep(3000)]);
    // A profile left behind is a warning, not the test's result.
    try {
      fs.rmSync(profile, { recursive: true, force: true, maxRetries: 10, retryDelay: 200 });
    } catch (e) {
      console.log(`${tool}: warning: the profile ${profile} was not removed: ${e.message}`);
    }
    process.exit(code);
  }
  chrome.on('exit', (code) => {
    if (!finished) finish(1, `${tool}: FAIL: chromium exited (${code}) early: ${chromeLog.split('\n').slice(-5).join(' | ')}`);
  });
  return { send, errors, finish };
}

// A new page attached in flat mode, with the given DevTools domains enabled: its sessionId.
export async function openPage(send, domains = ['Runtime', 'Page', 'Log']) {
  const { targetId } = await send('Target.createTarget', { url: 'about:blank' });
  const { sessionId } = await send('Target.attachToTarget', { targetId, flatten: true });
  for (const domain of domains) await send(`${domain}.enable`, {}, sessionId);
  return sessionId;
}
