// Opens a `rift layout` page in headless Chromium (Debian's, with software WebGL) and prints
// what the page shows as JSON: whether it loaded, its error message, the scene's counts and the
// share of each view's pixels that differ from its background; with --fps, also frames drawn
// per second (a second of drawing, for tools/layout_bench.py; the tests do not ask for it);
// with --ids W H, the shot camera's ID pass at W x H instead (object index per pixel).
//   node tests/browser/layout.mjs URL [SCREENSHOT.png] [--fps]
//   node tests/browser/layout.mjs URL --ids W H
//   node tests/browser/layout.mjs URL --steps JSON
//   node tests/browser/layout.mjs --serve
// --steps runs a list of steps in the page and prints each one's result: ["name", ...args]
// calls window.riftLayout.name(...args) (awaited); ["drag", dx, dy] drags the gizmo's centre
// in the orbit view by that many pixels with the mouse; ["error"] reads the message shown.
// --serve keeps one browser for many visits, each in a fresh context (its own storage): it reads
// requests as JSON lines on stdin, {"id": N, "argv": [URL, ...options]}, answers each with a
// line {"id": N, "result": ...} or {"id": N, "error": "..."} as it finishes (visits run at
// once), and closes the browser when stdin ends. The tests use it: a browser's start and its
// software-GL shader compilations cost about 6 s of processor time a visit, against 3 s for
// each further visit in the same browser.
import { chromium } from 'playwright-core';
import { createInterface } from 'node:readline';

const browser = await chromium.launch({
  executablePath: '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--disable-background-networking', '--disable-component-update',
         '--disable-sync', '--no-first-run', '--use-angle=swiftshader',
         '--enable-unsafe-swiftshader'],
});
// The tests' visits (--serve) draw a quarter of the pixels a person's window would: software GL
// draws every pixel on the processor, and the layout suite took 173 s of processor time at
// 1280 x 720 against 148 s at 640 x 360. The command-line form (screenshots, frame rates)
// keeps the full size.
const FULL_VIEW = { width: 1280, height: 720 };
const SMALL_VIEW = { width: 640, height: 360 };
const serving = process.argv[2] === '--serve';
if (serving) {
  const visits = [];
  for await (const line of createInterface({ input: process.stdin })) {
    if (!line.trim()) continue;
    const { id, argv } = JSON.parse(line);
    visits.push(visit(argv).then(
      result => ({ id, result }),
      e => ({ id, error: String(e && e.message || e) }),
    ).then(answer => process.stdout.write(JSON.stringify(answer) + '\n')));
  }
  await Promise.all(visits);
  await browser.close();
} else {
  try {
    console.log(JSON.stringify(await visit(process.argv.slice(2))));
  } catch (e) {
    console.error(`layout.mjs: ${e && e.message || e}`);
    process.exitCode = 2;
  } finally {
    await browser.close();
  }
}

// One visit of the page at argv[0] with the options after it: what the page reports.
async function visit([url, ...rest]) {
  const idSize = rest[0] === '--ids' ? [Number(rest[1]), Number(rest[2])] : null;
  // --camera X,Y,Z,TX,TY,TZ: move the shot camera first (as a drag would) and time the update;
  // --save: then save that pose into the shot file through the page; --check: run the check
  // render (one pass of 1 spp) and print its size.
  const cameraAt = rest.indexOf('--camera') >= 0 ? rest[rest.indexOf('--camera') + 1].split(',').map(Number) : null;
  const screenshot = rest.find(r => r.endsWith('.png')) || null;
  const context = await browser.newContext({ viewport: serving ? SMALL_VIEW : FULL_VIEW });
  const console_errors = [];
  // A page that stops answering (its draw loop died on an error, say) fails the visit with
  // what it threw, instead of hanging it.
  let timer;
  const timeout = new Promise((_, reject) => {
    timer = setTimeout(() => reject(new Error(
      `the page did not answer in 120 s; its errors: ${JSON.stringify(console_errors)}`)), 120000);
  });
  try {
    return await Promise.race([timeout, (async () => {
      const page = await context.newPage();
      page.on('pageerror', e => console_errors.push(String(e)));
      await page.goto(url);
      await page.waitForFunction(() => window.riftLayout && window.riftLayout.ready, null,
                                 { timeout: 60000 });
      let dragMs = null;
      if (cameraAt) {
        dragMs = await page.evaluate(c => window.riftLayout.setCamera(
          { position: c.slice(0, 3), lookAt: c.slice(3, 6) }), cameraAt);
      }
      if (rest.includes('--steps')) {
        const steps = JSON.parse(rest[rest.indexOf('--steps') + 1]);
        const results = [];
        for (const [name, ...args] of steps) results.push(await step(page, name, args));
        return { results, pageErrors: console_errors };
      } else if (rest.includes('--check')) {
        const size = await page.evaluate(() => window.riftLayout.checkRender([1]));
        if (screenshot) await page.screenshot({ path: screenshot });
        return { size, pageErrors: console_errors };
      } else if (rest.includes('--save')) {
        const saved = await page.evaluate(() => window.riftLayout.saveCamera());
        const shown = await page.evaluate(() => document.getElementById('error').textContent);
        return { saved, shown, pageErrors: console_errors };
      } else if (idSize) {
        const ids = await page.evaluate(([w, h]) => window.riftLayout.idPass(w, h), idSize);
        return { ids, dragMs, pageErrors: console_errors };
      }
      return report(page, console_errors, screenshot, rest.includes('--fps'));
    })()]);
  } finally {
    clearTimeout(timer);
    await context.close();
  }
}

async function step(page, name, args) {
  if (name === 'error') return page.evaluate(() => document.getElementById('error').textContent);
  if (name === 'drag') {
    const [x, y] = await page.evaluate(() => window.riftLayout.gizmoOnScreen());
    await page.mouse.move(x, y);
    await page.mouse.down();
    await page.mouse.move(x + args[0], y + args[1], { steps: 8 });
    await page.mouse.up();
    // The edit the drag's end sent has been answered once the page is ready again.
    return page.evaluate(() => window.riftLayout.idle());
  }
  return page.evaluate(([name, args]) => window.riftLayout[name](...args), [name, args]);
}

// The page's state and how much of each view it draws, as JSON; with `withFps`, its frame rate.
async function report(page, console_errors, screenshot, withFps) {
  // Frames drawn per second, asking for one after another for a second (the page draws only
  // when something changed).
  const fps = withFps && await page.evaluate(async () => {
    let frames = 0;
    const start = performance.now();
    while (performance.now() - start < 1000) {
      await window.riftLayout.redraw();
      frames += 1;
    }
    return frames * 1000 / (performance.now() - start);
  });
  const result = await page.evaluate(() => {
    const coverage = id => {
      const source = document.querySelector(`#${id} canvas`);
      const canvas = document.createElement('canvas');
      canvas.width = source.width;
      canvas.height = source.height;
      const ctx = canvas.getContext('2d');
      ctx.drawImage(source, 0, 0);
      const pixels = ctx.getImageData(0, 0, canvas.width, canvas.height).data;
      const [r0, g0, b0] = pixels.slice(0, 3);
      let differ = 0;
      for (let i = 0; i < pixels.length; i += 4) {
        if (Math.abs(pixels[i] - r0) + Math.abs(pixels[i + 1] - g0) +
            Math.abs(pixels[i + 2] - b0) > 24) differ += 1;
      }
      return differ / (pixels.length / 4);
    };
    const s = window.riftLayout.scene;
    return {
      error: window.riftLayout.error,
      frame: window.riftLayout.frame,
      objects: s ? s.objects.length : 0,
      openings: s ? s.openings.length : 0,
      orbitCoverage: coverage('orbit'),
      shotCoverage: coverage('shot'),
      errorShown: getComputedStyle(document.getElementById('error')).display !== 'none',
      errorText: document.getElementById('error').textContent,
    };
  });
  if (screenshot) await page.screenshot({ path: screenshot });
  return { ...result, ...(withFps ? { fps } : {}), pageErrors: console_errors };
}
