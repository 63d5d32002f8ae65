// parlight live viewer: connects to the ws:// stream (docs/OUTPUT.md) and shows, per frame,
// virtual objects lit by the frame's engine-ready lighting (docs/LIGHTING.md, "Engine-ready
// lighting"), the environment map of eq. (4), the lights as an overlay, and the camera frame when
// the stream carries one. docs/VIEWER.md describes the page, its query parameters and the
// `window.viewer` object the browser test reads.
//
// Colour: every light value is linear RGB. The renderer writes sRGB (outputColorSpace) after
// LinearToneMapping, which is clamp(exposure * colour): no curve, so a pixel p of the screen is
// exposure * radiance through the sRGB transfer function, comparable with the linear output of
// `parlight render --sphere diffuse` (tests/test_viewer.sh does the comparison).
import * as THREE from 'three';

const params = new URLSearchParams(location.search);
// ws: the stream's URL (default: this server's /stream, what `parlight view` serves);
// freeze=N: keep the N-th frame received on screen and ignore later ones (screenshots, tests);
// shadows=0: no shadow map; probe=0: the main view lit by the directional light alone;
// exposure=X: a fixed exposure instead of the automatic one.
const WS_URL = params.get('ws') ||
    `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/stream`;
const FREEZE = Math.max(0, parseInt(params.get('freeze') || '0', 10) || 0);
const FIXED_EXPOSURE = parseFloat(params.get('exposure') || '');

// Layout of the reference sphere (CSS px, from the bottom-right corner; #refbox in viewer.css).
const REF_SIZE = 160, REF_MARGIN = 12;
// The small scene: the capture camera sits at the origin looking along -z (parlight's camera
// frame = three.js world here), the objects stand on a ground plane in front of it.
const GROUND_Y = -1.0, SCENE_Z = -4.0;
const DIFFUSE_AT = new THREE.Vector3(-0.65, GROUND_Y + 0.45, SCENE_Z);
const GLOSSY_AT = new THREE.Vector3(0.65, GROUND_Y + 0.45, SCENE_Z);
const SPHERE_R = 0.45;

// ---- the one conversion from a stream line to three.js lights -------------------------------
// engine.dir, engine.intensity and engine.sh9 are already in three.js's conventions: sh9 is the
// radiance SH in WebXR order (Y00, Y1-1 ~ y, Y10 ~ z, Y11 ~ x, Y2-2 ~ xy, Y2-1 ~ yz, Y20,
// Y21 ~ xz, Y22), orthonormal basis without the Condon-Shortley phase, RGB interleaved, which is
// exactly what SphericalHarmonics3.fromArray takes and what shGetIrradianceAt (three.js
// lights_pars_begin) turns into irradiance with the factors pi, 2pi/3, pi/4. intensity is the
// directional light's irradiance at normal incidence (three.js r155+: irradiance = dotNL *
// color * intensity; no legacy pi factor since useLegacyLights was removed in r165). So nothing
// is rescaled: colours are set as linear RGB.
export function applyEngineLighting(engine, dl, probe) {
    const [r, g, b] = engine.intensity;
    dl.color.setRGB(r, g, b, THREE.LinearSRGBColorSpace);
    dl.intensity = 1;
    dl.position.fromArray(engine.dir).normalize().multiplyScalar(10).add(dl.target.position);
    probe.sh.fromArray(engine.sh9);
    probe.intensity = 1;
}

// Irradiance (linear RGB) that the directional light + probe deliver on a surface of normal n,
// the same sums as three.js's shaders (tests use it to choose an exposure, nothing else).
function engineIrradiance(engine, n, out) {
    const [x, y, z] = n, c = engine.sh9;
    const d = engine.dir, dn = Math.hypot(d[0], d[1], d[2]) || 1;
    const cosl = Math.max(0, (x * d[0] + y * d[1] + z * d[2]) / dn);
    const basis = [0.886227, 2 * 0.511664 * y, 2 * 0.511664 * z, 2 * 0.511664 * x,
        2 * 0.429043 * x * y, 2 * 0.429043 * y * z, 0.743125 * z * z - 0.247708,
        2 * 0.429043 * x * z, 0.429043 * (x * x - y * y)];
    for (let k = 0; k < 3; k++) {
        let e = cosl * engine.intensity[k];
        for (let i = 0; i < 9; i++) e += basis[i] * c[3 * i + k];
        out[k] = e;
    }
    return out;
}

// Exposure that puts the brightest pixel of the white diffuse sphere (radiance E/pi over the
// normals facing the camera) at 0.9, so that nothing on it clips.
function autoExposure(engine) {
    let peak = 0;
    const e = [0, 0, 0];
    for (let i = 0; i < 24; i++) {
        for (let j = 0; j < 24; j++) {
            const sx = (i + 0.5) / 12 - 1, sy = (j + 0.5) / 12 - 1, r2 = sx * sx + sy * sy;
            if (r2 > 1) continue;
            engineIrradiance(engine, [sx, sy, Math.sqrt(1 - r2)], e);
            peak = Math.max(peak, e[0] / Math.PI, e[1] / Math.PI, e[2] / Math.PI);
        }
    }
    return peak > 0 ? 0.9 / peak : 1;
}

// ---- the environment map of eq. (4) --------------------------------------------------------
// L(u) = sum_i c_i exp((l_i.u - 1) / (s_i / 4pi)) + a, docs/OUTPUT.md "What the numbers mean".
function radiance(frame, u, out) {
    out[0] = frame.ambient[0];
    out[1] = frame.ambient[1];
    out[2] = frame.ambient[2];
    for (const l of frame.lights) {
        const d = l.dir, dn = Math.hypot(d[0], d[1], d[2]) || 1;
        const dot = (d[0] * u[0] + d[1] * u[1] + d[2] * u[2]) / dn;
        const w = Math.exp((dot - 1) * 4 * Math.PI / l.solid_angle_sr);
        out[0] += w * l.rgb[0];
        out[1] += w * l.rgb[1];
        out[2] += w * l.rgb[2];
    }
    return out;
}

const ENV_W = 256, ENV_H = 128;
// three.js's equirectangular convention (equirectUv): u = atan2(z, x) / 2pi + 0.5, v = asin(y) /
// pi + 0.5, row 0 of a DataTexture at v = 0. A new texture per frame: three.js converts an
// equirectangular background to a cube map once per texture and does not redo it on needsUpdate.
function envTexture(frame) {
    const tex = new THREE.DataTexture(new Uint16Array(ENV_W * ENV_H * 4), ENV_W, ENV_H,
        THREE.RGBAFormat, THREE.HalfFloatType);
    tex.mapping = THREE.EquirectangularReflectionMapping;
    tex.colorSpace = THREE.LinearSRGBColorSpace;
    tex.magFilter = tex.minFilter = THREE.LinearFilter;
    const data = tex.image.data, c = [0, 0, 0];
    for (let j = 0; j < ENV_H; j++) {
        const lat = ((j + 0.5) / ENV_H - 0.5) * Math.PI;
        for (let i = 0; i < ENV_W; i++) {
            const phi = ((i + 0.5) / ENV_W - 0.5) * 2 * Math.PI;
            radiance(frame, [Math.cos(phi) * Math.cos(lat), Math.sin(lat),
                Math.sin(phi) * Math.cos(lat)], c);
            const o = 4 * (j * ENV_W + i);
            data[o] = THREE.DataUtils.toHalfFloat(c[0]);
            data[o + 1] = THREE.DataUtils.toHalfFloat(c[1]);
            data[o + 2] = THREE.DataUtils.toHalfFloat(c[2]);
            data[o + 3] = THREE.DataUtils.toHalfFloat(1);
        }
    }
    tex.needsUpdate = true;
    return tex;
}

function srgb8(v) {
    v = Math.min(1, Math.max(0, v));
    return Math.round(255 * (v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055));
}

// The 2D panorama in parlight's own convention (light/equirect.h: centre = the camera's forward
// -z, right = +x, top = +y), tonemapped like `parlight render` (99th percentile -> 1, sRGB), with
// a ring per light in its colour.
function drawEnvPanel(frame, canvas) {
    const g = canvas.getContext('2d'), W = canvas.width, H = canvas.height;
    const img = g.createImageData(W, H), vals = new Float32Array(W * H * 3), c = [0, 0, 0];
    for (let y = 0; y < H; y++) {
        const th = (0.5 - (y + 0.5) / H) * Math.PI;
        for (let x = 0; x < W; x++) {
            const ph = ((x + 0.5) / W - 0.5) * 2 * Math.PI;
            radiance(frame, [Math.sin(ph) * Math.cos(th), Math.sin(th),
                -Math.cos(ph) * Math.cos(th)], c);
            vals.set(c, 3 * (y * W + x));
        }
    }
    const sorted = Float32Array.from(vals).sort();
    const p99 = sorted[Math.floor(0.99 * (sorted.length - 1) + 0.5)] || 1;
    for (let i = 0; i < W * H; i++) {
        for (let k = 0; k < 3; k++) img.data[4 * i + k] = srgb8(vals[3 * i + k] / p99);
        img.data[4 * i + 3] = 255;
    }
    g.putImageData(img, 0, 0);
    for (const l of frame.lights) {
        const d = l.dir, n = Math.hypot(d[0], d[1], d[2]) || 1;
        const ph = Math.atan2(d[0] / n, -d[2] / n), th = Math.asin(Math.max(-1, Math.min(1, d[1] / n)));
        const px = (ph / (2 * Math.PI) + 0.5) * W, py = (0.5 - th / Math.PI) * H;
        g.lineWidth = 2;
        g.strokeStyle = '#000';
        g.beginPath(); g.arc(px, py, 7, 0, 2 * Math.PI); g.stroke();
        g.strokeStyle = cssColour(l.rgb);
        g.beginPath(); g.arc(px, py, 5, 0, 2 * Math.PI); g.stroke();
    }
}

// A light's chromaticity as a CSS colour (brightest channel at full scale).
function cssColour(rgb) {
    const m = Math.max(rgb[0], rgb[1], rgb[2], 1e-12);
    return `rgb(${srgb8(rgb[0] / m)},${srgb8(rgb[1] / m)},${srgb8(rgb[2] / m)})`;
}

// ---- scenes -------------------------------------------------------------------------------
const canvas = document.getElementById('gl');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.outputColorSpace = THREE.SRGBColorSpace;
renderer.toneMapping = THREE.LinearToneMapping;
renderer.shadowMap.enabled = params.get('shadows') !== '0';
renderer.shadowMap.type = THREE.PCFSoftShadowMap;
renderer.autoClear = false;

function engineLights(withShadow) {
    const dl = new THREE.DirectionalLight(0xffffff, 1);
    const probe = new THREE.LightProbe();
    if (withShadow) {
        dl.castShadow = true;
        dl.shadow.mapSize.set(2048, 2048);
        const sc = dl.shadow.camera;
        sc.left = sc.bottom = -3;
        sc.right = sc.top = 3;
        sc.near = 0.5;
        sc.far = 25;
        dl.shadow.bias = -0.0003;
        dl.shadow.normalBias = 0.01;
    }
    return { dl, probe };
}

// The main view: two spheres and a box on a ground plane, the env map behind, arrows toward the
// lights.
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(50, 1, 0.1, 100);
camera.position.set(0, 0, 0);
camera.lookAt(0, GROUND_Y + 0.1, SCENE_Z);
const main = engineLights(true);
if (params.get('probe') === '0') main.probe.intensity = 0;
main.dl.target.position.set(0, GROUND_Y, SCENE_Z);
scene.add(main.dl, main.dl.target, main.probe);
const white = new THREE.Color(1, 1, 1);
const diffuse = new THREE.Mesh(new THREE.SphereGeometry(SPHERE_R, 96, 48),
    new THREE.MeshLambertMaterial({ color: white }));
diffuse.position.copy(DIFFUSE_AT);
const glossy = new THREE.Mesh(new THREE.SphereGeometry(SPHERE_R, 96, 48),
    new THREE.MeshStandardMaterial({ color: white, roughness: 0.2, metalness: 0 }));
glossy.position.copy(GLOSSY_AT);
const box = new THREE.Mesh(new THREE.BoxGeometry(0.35, 0.35, 0.35),
    new THREE.MeshLambertMaterial({ color: new THREE.Color(0.8, 0.35, 0.2) }));
box.position.set(0, GROUND_Y + 0.175, SCENE_Z + 0.8);
box.rotation.y = 0.5;
const ground = new THREE.Mesh(new THREE.PlaneGeometry(8, 8),
    new THREE.MeshLambertMaterial({ color: new THREE.Color(0.6, 0.6, 0.6) }));
ground.rotation.x = -Math.PI / 2;
ground.position.set(0, GROUND_Y, SCENE_Z);
for (const m of [diffuse, glossy, box]) m.castShadow = true;
ground.receiveShadow = true;
scene.add(diffuse, glossy, box, ground);
const arrows = new THREE.Group();
scene.add(arrows);

// The reference: a white diffuse sphere of radius 1 filling a REF_SIZE square, orthographic,
// camera looking along -z: the geometry of `parlight render --sphere diffuse --size REF_SIZE`.
const refScene = new THREE.Scene();
const refCamera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.1, 10);
refCamera.position.set(0, 0, 5);
const ref = engineLights(false);
refScene.add(ref.dl, ref.dl.target, ref.probe);
refScene.add(new THREE.Mesh(new THREE.SphereGeometry(1, 256, 128),
    new THREE.MeshLambertMaterial({ color: white })));

function updateArrows(frame) {
    arrows.clear();
    const origin = new THREE.Vector3(0, GROUND_Y + 1.05, SCENE_Z - 0.6);
    const peak = Math.max(1e-12, ...frame.lights.map(l => Math.max(...l.rgb) * l.solid_angle_sr));
    for (const l of frame.lights) {
        const d = new THREE.Vector3().fromArray(l.dir).normalize();
        const m = Math.max(...l.rgb, 1e-12);
        const colour = new THREE.Color().setRGB(l.rgb[0] / m, l.rgb[1] / m, l.rgb[2] / m,
            THREE.LinearSRGBColorSpace);
        // length by the lobe's energy (about c * s / 2), at least a stub for a faint light
        const len = 0.25 + 0.35 * Math.sqrt(m * l.solid_angle_sr / peak);
        const a = new THREE.ArrowHelper(d, origin, len, colour, 0.1, 0.06);
        a.line.material.toneMapped = false;
        a.cone.material.toneMapped = false;
        arrows.add(a);
    }
    // the room's key light over views (estimate --fuse), when the line has one: a longer white
    // arrow with a wide head, in the same space as the lights (world: --fuse needs --poses)
    viewer.keyArrow = null;
    if (frame.key_light) {
        const d = new THREE.Vector3().fromArray(frame.key_light.dir).normalize();
        const a = new THREE.ArrowHelper(d, origin, 1.0, 0xffffff, 0.18, 0.12);
        a.line.material.toneMapped = false;
        a.cone.material.toneMapped = false;
        a.name = 'key light';
        arrows.add(a);
        viewer.keyArrow = d.toArray();
    }
}

// ---- state, exposed for tests and curious users -------------------------------------------
const viewer = {
    frames: 0,          // lines received
    shown: 0,           // lines applied to the scene
    frame: null,        // the line on screen (parsed)
    keyArrow: null,     // the key light arrow's unit direction, when the line has a key light
    line: '',           // ... and as received
    exposure: 1,
    ref: { right: REF_MARGIN, bottom: REF_MARGIN, size: REF_SIZE },
    // the objects that cast shadows on the ground (centre and height above the ground, m)
    scene: { groundY: GROUND_Y, casters: [diffuse, glossy, box].map(m => ({
        centre: m.position.toArray(), height: m.position.y - GROUND_Y })) },
    error: null,
    three: { THREE, renderer, scene, camera, lights: main }, // for the console
    // CSS-pixel position of a world point in the main view (tests locate the shadow with it).
    project(p) {
        const v = new THREE.Vector3().fromArray(p).project(camera);
        return [(v.x + 1) / 2 * innerWidth, (1 - v.y) / 2 * innerHeight];
    },
    setShadows(on) {
        main.dl.castShadow = !!on;
        return redraw();
    },
    // off: the directional light alone (the probe's share hidden), to see the primary light's
    // shadow at full contrast; the reference sphere keeps both
    setProbe(on) {
        main.probe.intensity = on ? 1 : 0;
        return redraw();
    },
};
window.viewer = viewer;

function redraw() {
    render();
    return new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)));
}

function render() {
    const W = innerWidth, H = innerHeight;
    renderer.setSize(W, H, false);
    camera.aspect = W / H;
    camera.updateProjectionMatrix();
    renderer.toneMappingExposure = viewer.exposure;
    renderer.setScissorTest(false);
    renderer.setViewport(0, 0, W, H);
    renderer.setClearColor(0x000000, 1);
    renderer.clear();
    renderer.render(scene, camera);
    const x = W - REF_MARGIN - REF_SIZE, y = REF_MARGIN;
    renderer.setViewport(x, y, REF_SIZE, REF_SIZE);
    renderer.setScissor(x, y, REF_SIZE, REF_SIZE);
    renderer.setScissorTest(true);
    renderer.setClearColor(0x000000, 1); // the shadow pass leaves white as the clear colour
    renderer.clear();
    renderer.render(refScene, refCamera);
    renderer.setScissorTest(false);
}

// What the page relies on in a line (docs/OUTPUT.md), or why it cannot use it.
function checkLine(f) {
    const nums = (a, n) => Array.isArray(a) && (n === undefined || a.length === n) &&
        a.every(v => typeof v === 'number' && Number.isFinite(v));
    if (!f || typeof f !== 'object' || !f.engine) return 'no "engine": not a parlight stream?';
    if (!nums(f.engine.dir, 3) || !nums(f.engine.intensity, 3) || !nums(f.engine.sh9, 27))
        return '"engine" needs dir[3], intensity[3] and sh9[27] numbers';
    if (!nums(f.ambient, 3) || !Array.isArray(f.lights)) return 'no "lights" or "ambient"';
    if (f.key_light !== undefined && f.key_light !== null &&
        (!nums(f.key_light.dir, 3) || !Number.isInteger(f.key_light.views) ||
            f.key_light.views < 1))
        return '"key_light" needs dir[3] numbers and views >= 1 (or null)';
    for (const l of f.lights) {
        if (!l || !nums(l.dir, 3) || !nums(l.rgb, 3) || !(l.solid_angle_sr > 0))
            return 'a light without dir[3], rgb[3] and solid_angle_sr > 0';
    }
    return null;
}

const stamps = [];
function onFrame(line) {
    let f;
    try {
        f = JSON.parse(line);
    } catch (e) {
        setStatus(`bad message: ${e.message}`);
        return;
    }
    if (f.error) { // {"error":"refused","reason":...}: the server says why and closes
        viewer.error = f.reason || f.error;
        setStatus(`refused: ${viewer.error}`);
        return;
    }
    const why = checkLine(f);
    if (why) {
        setStatus(`ignored a message: ${why}`);
        return;
    }
    viewer.frames++;
    document.body.dataset.frames = String(viewer.frames);
    const now = performance.now();
    stamps.push(now);
    while (stamps.length > 10) stamps.shift();
    if (FREEZE && viewer.shown >= FREEZE) {
        document.title = `parlight viewer: ${viewer.frames} frames, frozen at ${viewer.frame.frame}`;
        return;
    }
    viewer.frame = f;
    viewer.line = line;
    viewer.shown++;
    const probeOn = main.probe.intensity;
    applyEngineLighting(f.engine, main.dl, main.probe);
    applyEngineLighting(f.engine, ref.dl, ref.probe);
    main.probe.intensity = probeOn;
    viewer.exposure = FIXED_EXPOSURE > 0 ? FIXED_EXPOSURE : autoExposure(f.engine);
    const old = scene.background;
    scene.background = envTexture(f);
    if (old) old.dispose();
    drawEnvPanel(f, document.getElementById('env'));
    updateArrows(f);
    showThumb(f);
    document.getElementById('frame').textContent = String(f.frame);
    document.getElementById('source').textContent = f.source || '';
    document.getElementById('primary').textContent =
        f.primary ? f.primary.dir.map(v => v.toFixed(2)).join(', ') : '-';
    document.getElementById('exposure').textContent = viewer.exposure.toPrecision(3);
    const k = f.key_light;
    document.getElementById('keylight').textContent = k === undefined ? '- (estimate --fuse)'
        : k === null ? 'no view with light yet'
        : `${k.dir.map(v => v.toFixed(2)).join(', ')} (${k.views} view${k.views === 1 ? '' : 's'})`;
    document.getElementById('rate').textContent = stamps.length > 1
        ? ((stamps.length - 1) * 1000 / (now - stamps[0])).toFixed(1) : '-';
    render();
    document.body.dataset.shown = String(viewer.shown);
    document.title = `parlight viewer: ${viewer.frames} frames` +
        (FREEZE && viewer.shown >= FREEZE ? `, frozen at ${f.frame}` : '');
}

// The camera frame, when the line carries one: "thumb", a base64 JPEG (or a data: URL).
function showThumb(f) {
    const img = document.getElementById('thumb'), none = document.getElementById('nothumb');
    if (typeof f.thumb === 'string' && f.thumb.length) {
        img.src = f.thumb.startsWith('data:') ? f.thumb : `data:image/jpeg;base64,${f.thumb}`;
        img.hidden = false;
        none.hidden = true;
    } else {
        img.hidden = true;
        none.hidden = false;
    }
}

function setStatus(s) {
    document.getElementById('status').textContent = s;
}

let retry = 500;
function connect() {
    setStatus(`connecting to ${WS_URL}`);
    let ws;
    try {
        ws = new WebSocket(WS_URL);
    } catch (e) {
        setStatus(`cannot open ${WS_URL}: ${e.message}`);
        return;
    }
    ws.onopen = () => { retry = 500; setStatus(`connected to ${WS_URL}`); };
    ws.onmessage = ev => { if (typeof ev.data === 'string') onFrame(ev.data); };
    ws.onclose = ev => {
        const why = ev.reason ? ` (${ev.code} ${ev.reason})` : ` (${ev.code})`;
        setStatus(`disconnected${why}; again in ${(retry / 1000).toFixed(1)} s`);
        if (viewer.error) return; // refused: trying again would be refused again
        setTimeout(connect, retry);
        retry = Math.min(retry * 2, 8000);
    };
}

addEventListener('resize', render);
render();
connect();
