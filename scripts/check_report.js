// Drives headless Chromium over the DevTools protocol (--remote-debugging-pipe: JSON messages ending in a NUL byte
// on file descriptors 3 and 4) to check a report page as a person would open it; used by scripts/check_report.
//   node scripts/check_report.js INDEX_HTML SCREENSHOT_PNG [--sort]
// Prints one JSON object: items, rows, requested, loaded, failed models, the models' distinct colour counts, the
// console errors and exceptions, the seconds from navigation to every model in view loaded (the page's own clock,
// and the harness's), the first model's box; writes the screenshot and, beside it, the first model's view alone.
'use strict';
const {spawn} = require('child_process');
const fs = require('fs');
const os = require('os');
const path = require('path');

const [page, screenshot] = process.argv.slice(2);
const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'sdfkit-chromium-'));
const args = ['--headless', '--remote-debugging-pipe', '--no-first-run', '--no-default-browser-check',
  '--user-data-dir=' + profile, '--window-size=1280,1000', '--hide-scrollbars',
  // WebGL without a GPU: ANGLE on SwiftShader, the software renderer Chromium ships.
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader'];
if (process.getuid && process.getuid() === 0) args.push('--no-sandbox');  // Chromium refuses root with its sandbox
const browser = spawn('chromium', args, {stdio: ['ignore', 'ignore', 'ignore', 'pipe', 'pipe']});
const toBrowser = browser.stdio[3], fromBrowser = browser.stdio[4];

let nextId = 1, buffer = '';
const pending = new Map(), listeners = [];
fromBrowser.on('data', (chunk) => {
  buffer += chunk.toString('utf8');
  let end;
  while ((end = buffer.indexOf('\0')) >= 0) {
    const msg = JSON.parse(buffer.slice(0, end));
    buffer = buffer.slice(end + 1);
    if (msg.id !== undefined && pending.has(msg.id)) {
      const {resolve, reject} = pending.get(msg.id);
      pending.delete(msg.id);
      if (msg.error) reject(new Error(JSON.stringify(msg.error))); else resolve(msg.result);
    } else {
      for (const l of listeners) l(msg);
    }
  }
});
function send(method, params = {}, sessionId) {
  const id = nextId++;
  const msg = {id, method, params};
  if (sessionId) msg.sessionId = sessionId;
  toBrowser.write(JSON.stringify(msg) + '\0');
  return new Promise((resolve, reject) => pending.set(id, {resolve, reject}));
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function main() {
  const {targetId} = await send('Target.createTarget', {url: 'about:blank'});
  const {sessionId} = await send('Target.attachToTarget', {targetId, flatten: true});
  const s = (m, p) => send(m, p, sessionId);
  const errors = [];
  listeners.push((msg) => {
    if (msg.sessionId !== sessionId) return;
    if (msg.method === 'Runtime.consoleAPICalled' && (msg.params.type === 'error' || msg.params.type === 'assert'))
      errors.push('console: ' + msg.params.args.map((a) => a.value ?? a.description).join(' '));
    if (msg.method === 'Runtime.exceptionThrown')
      errors.push('exception: ' + (msg.params.exceptionDetails.exception?.description ?? msg.params.exceptionDetails.text));
    if (msg.method === 'Log.entryAdded' && msg.params.entry.level === 'error')
      errors.push('log: ' + msg.params.entry.text + (msg.params.entry.url ? ' (' + msg.params.entry.url + ')' : ''));
  });
  await s('Runtime.enable');
  await s('Log.enable');
  await s('Page.enable');
  const evaluate = async (expr) => (await s('Runtime.evaluate', {expression: expr, returnByValue: true})).result.value;
  const t0 = Date.now();
  await s('Page.navigate', {url: 'file://' + path.resolve(page) + '#check'});
  let ready = null;
  while (Date.now() - t0 < 60000) {
    if (await evaluate('document.body && document.body.dataset.ready === "1"')) { ready = (Date.now() - t0) / 1000; break; }
    await sleep(20);
  }
  // The in-page check of each loaded model's frame (colours) runs just after; wait for it.
  const t1 = Date.now();
  while (Date.now() - t1 < 20000 &&
         !(await evaluate('Array.from(document.querySelectorAll("model-viewer[data-state=loaded]")).every(v => v.dataset.colours)')))
    await sleep(50);
  const state = await evaluate(`(() => {
    const b = document.body.dataset, vs = Array.from(document.querySelectorAll('model-viewer[data-k]'));
    return {items: +b.items, rows: document.querySelectorAll('#items tbody tr').length, requested: +b.requested,
            loaded: +b.loaded, failed: +b.failed, page_errors: document.getElementById('errors').textContent,
            colours: vs.filter(v => v.dataset.state === 'loaded').map(v => +v.dataset.colours),
            first_viewer: b.firstViewer || '', page_seconds_to_ready: b.readyMs ? b.readyMs / 1000 : null};
  })()`);
  state.seconds_to_ready = ready;  // the harness's clock: includes the first navigation of a new browser profile
  state.errors = errors;
  const shot = await s('Page.captureScreenshot', {format: 'png'});
  fs.writeFileSync(screenshot, Buffer.from(shot.data, 'base64'));
  if (state.first_viewer) {
    const [x, y, width, height] = state.first_viewer.split(',').map(Number);
    const clip = await s('Page.captureScreenshot', {format: 'png', clip: {x, y, width, height, scale: 1}});
    fs.writeFileSync(screenshot.replace(/\.png$/, '') + '.viewer.png', Buffer.from(clip.data, 'base64'));
  }
  // Sorting: a click on the IoU header puts the rows in increasing IoU order.
  state.sorted = await evaluate(`(() => {
    const ths = Array.from(document.querySelectorAll('#items th'));
    const col = ths.findIndex(t => t.textContent.startsWith('IoU'));
    ths[col].click();
    const v = Array.from(document.querySelectorAll('#items tbody tr')).map(r => r.cells[col].dataset.v).filter(x => x !== '').map(Number);
    return v.every((x, i) => i === 0 || v[i - 1] <= x);
  })()`);
  process.stdout.write(JSON.stringify(state) + '\n');
}

main().then(() => 0, (e) => { process.stderr.write('check_report.js: ' + e.message + '\n'); return 1; }).then((rc) => {
  browser.on('exit', () => {
    fs.rmSync(profile, {recursive: true, force: true});
    process.exit(rc);
  });
  browser.kill();
});
