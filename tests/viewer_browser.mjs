// Drives Debian's headless Chromium on the live viewer for tests/test_viewer.sh (not a test by
// itself): opens URL, waits until the page has shown FREEZE frames (the page keeps that frame on
// screen and counts the later ones), takes a screenshot with shadows and one without, and writes
// the page's state (the line on screen, exposure, where the reference sphere is, screen positions
// of the scene's points) as JSON. playwright-core comes from app/viewer/node_modules (npm ci);
// it downloads nothing and only talks to /usr/bin/chromium over a pipe.
//   node tests/viewer_browser.mjs URL OUTDIR [CHROMIUM]
// Exit 0 on success, 3 when the browser has no WebGL (the test skips), 1 otherwise.
import { createRequire } from 'node:module';
import { writeFileSync } from 'node:fs';
import path from 'node:path';

const [url, out, exe = '/usr/bin/chromium'] = process.argv.slice(2);
const require = createRequire(path.resolve('app/viewer/package.json'));
const { chromium } = require('playwright-core');
const WIDTH = 1024, HEIGHT = 640, FREEZE = 2, WAIT_MS = 60000;

const t0 = Date.now();
const log = msg => console.log(`[${((Date.now() - t0) / 1000).toFixed(1)} s] ${msg}`);
const browser = await chromium.launch({
    executablePath: exe,
    headless: true,
    timeout: 30000,
    // software WebGL (SwiftShader): no GPU here; sRGB output so screenshot pixels are what the
    // page wrote; --no-sandbox because the tests may run as root
    args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--force-color-profile=srgb',
        '--no-sandbox', '--disable-dev-shm-usage'],
});
let code = 1;
try {
    const page = await browser.newPage({ viewport: { width: WIDTH, height: HEIGHT },
        deviceScaleFactor: 1 });
    const errors = [];
    page.on('pageerror', e => errors.push(String(e)));
    page.on('console', m => { if (m.type() === 'error') errors.push(m.text()); });
    await page.goto(`${url}?freeze=${FREEZE}`, { timeout: 20000 });
    log('page loaded');
    const webgl = await page.evaluate(() => !!document.createElement('canvas').getContext('webgl2'));
    if (!webgl) {
        console.log('no WebGL2 in this headless chromium');
        code = 3;
    } else {
        await page.waitForFunction(n => window.viewer && window.viewer.shown >= n, FREEZE,
            { timeout: WAIT_MS });
        log(`page showed ${FREEZE} frames`);
        // frames keep arriving while the frozen one stays on screen
        await page.waitForFunction(n => window.viewer.frames >= n, FREEZE + 2,
            { timeout: WAIT_MS });
        await page.waitForFunction(() => document.getElementById('thumb').complete,
            null, { timeout: 10000 });
        await page.evaluate(() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r))));
        await page.screenshot({ path: path.join(out, 'viewer.png') });
        const state = await page.evaluate(() => {
            const v = window.viewer, s = v.scene;
            const casters = s.casters.map(c => ({ centre: c.centre, height: c.height }));
            const pts = {};
            const d = v.frame.engine.dir, n = Math.hypot(...d);
            for (const [i, c] of casters.entries()) {
                const base = [c.centre[0], s.groundY, c.centre[2]];
                pts[`base${i}`] = v.project(base);
                // where the centre's shadow falls: along -dir from the centre down to the ground
                const t = (c.centre[1] - s.groundY) / (d[1] / n);
                pts[`shadow${i}`] = v.project(c.centre.map((x, k) => x - t * d[k] / n));
                pts[`light${i}`] = v.project(base.map((x, k) => x + 0.5 * d[k] / n));
            }
            return { frames: v.frames, shown: v.shown, line: v.line, exposure: v.exposure,
                ref: v.ref, width: innerWidth, height: innerHeight, title: document.title,
                dom_frames: document.body.dataset.frames, casters, points: pts, key: v.keyArrow,
                key_text: document.getElementById('keylight').textContent,
                thumb: (im => ({ shown: !im.hidden, width: im.naturalWidth, height: im.naturalHeight,
                    rect: im.getBoundingClientRect().toJSON() }))(document.getElementById('thumb')) };
        });
        await page.evaluate(() => window.viewer.setShadows(false));
        await page.screenshot({ path: path.join(out, 'noshadow.png') });
        // the directional light alone: its shadow at full contrast
        await page.evaluate(() => window.viewer.setProbe(false));
        await page.screenshot({ path: path.join(out, 'direct-noshadow.png') });
        await page.evaluate(() => window.viewer.setShadows(true));
        await page.screenshot({ path: path.join(out, 'direct.png') });
        state.errors = errors;
        state.seconds = (Date.now() - t0) / 1000;
        writeFileSync(path.join(out, 'state.json'), JSON.stringify(state, null, 1));
        log(`state and screenshots in ${out}`);
        code = errors.length ? 1 : 0;
        if (errors.length) console.log(`page errors: ${errors.join(' | ')}`);
    }
} catch (e) {
    console.log(`browser: ${e.message}`);
} finally {
    await browser.close();
}
process.exit(code);
