// swarmnav replay viewer: reads the run embedded in the page (#swarmnav-data) and draws it
// top-down (2-D canvas) or in perspective (three.js r185 + OrbitControls, vendored and loaded
// from blob URLs: nothing is fetched). window.swarmnav is the hook the tests drive.
(() => {
  'use strict';
  const D = JSON.parse(document.getElementById('swarmnav-data').textContent);
  const K = D.K, N = D.N, DIM = D.dim, DT = D.dt;
  const $ = id => document.getElementById(id);
  const stage = $('stage'), top = $('top'), persp = $('persp'), tip = $('tip'), scrub = $('scrub');
  const chart = $('chart'), speedSel = $('speed'), viewSel = $('view'), playBtn = $('play');
  const ctx = top.getContext('2d'), cctx = chart.getContext('2d');
  const TRAIL_SECONDS = 3, TRAIL_POINTS = 12, BANDS = [0.12, 0.25, 0.45, 0.7];
  const OBST_FACE = '#b3d9f2', OBST_EDGE = '#4d7ea8', GOAL = '#ffd400', SOLID = '#c5cad3', SOLID_EDGE = '#59606b';
  const PATH = '#9467bd';  // tab:purple, the figures' path colour
  // committed plans: dashed lines in the agent's colour (dashes: ahead, against the trail behind)
  const PLAN_WIDTH = 1.5, PLAN_ALPHA = 0.9, PLAN_DASH = [6, 3];  // [css px]
  const ROLE_NAMES = D.roles || null;
  // a quadrotor run's thrust axes (D.thrust): a dark stick from each agent along its body z axis
  const AXIS_COLOR = '#222', AXIS_PX = 40;  // top-down: a 40 css px stick seen from above (a level vehicle's: a point)
  const LARGE = N > 300;  // a large swarm: cheaper drawing (see buildScene)

  // ------------------------------------------------------------------ data
  const TYPES = {uint8: Uint8Array, uint16: Uint16Array, uint32: Uint32Array, float32: Float32Array};
  function bytes(s) {
    if (Uint8Array.fromBase64) return Uint8Array.fromBase64(s);
    const bin = atob(s), u = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) u[i] = bin.charCodeAt(i);
    return u;
  }
  async function decode(b) {
    const stream = new Blob([bytes(b.data)]).stream().pipeThrough(new DecompressionStream('gzip'));
    const a = new TYPES[b.dtype](await new Response(stream).arrayBuffer());
    if (b.delta) {  // uint16 differences along time: add them back up (Uint16Array wraps mod 2^16)
      const row = a.length / b.shape[0];
      for (let i = row; i < a.length; i++) a[i] += a[i - row];
    }
    return a;
  }
  function dequantise(codes, lo, hi) {
    const out = new Float32Array(codes.length), L = D.quant.levels;
    const scale = lo.map((l, j) => (hi[j] > l ? hi[j] - l : 1) / L);
    for (let i = 0; i < codes.length; i += DIM)
      for (let j = 0; j < DIM; j++) out[i + j] = lo[j] + codes[i + j] * scale[j];
    return out;
  }
  let P, V, C, LAB, ROLE, MINC, NSUB, AX = null;
  // committed trajectories (D.plans, when the run recorded them): plan j of robot PL.robot[j],
  // committed at step PL.step[j], is points PL.pts[off[j] .. off[j + 1]) at run times PL.t[...]
  const PL = {byRobot: null, maxLen: 0};
  async function load() {
    const A = D.arrays, q = D.quant;
    const [p, v, c, lab, minc, nsub, role, pstep, probot, poff, ppts, ptau, ax] = await Promise.all(
      ['positions', 'velocities', 'clearance', 'labels', 'min_clearance', 'n_subswarms', 'roles',
       'plan_step', 'plan_robot', 'plan_offsets', 'plan_points', 'plan_tau', 'thrust_axis']
        .map(k => A[k] ? decode(A[k]) : null));
    P = dequantise(p, q.lo, q.hi);
    V = dequantise(v, q.lo.map(() => -q.vmax), q.lo.map(() => q.vmax));
    C = c; LAB = lab; MINC = minc; NSUB = nsub; ROLE = role;
    if (D.thrust) {  // unit body z axes, (K + 1) x N x 3, coded over [-1, 1] per component
      const L = D.thrust.levels;
      AX = new Float32Array(ax.length);
      for (let j = 0; j < ax.length; j++) AX[j] = -1 + ax[j] * 2 / L;
    }
    if (D.plans) {
      const t = new Float64Array(ptau.length), lists = Array.from({length: N}, () => []);
      for (let j = 0; j < pstep.length; j++) {
        for (let r = poff[j]; r < poff[j + 1]; r++) t[r] = pstep[j] * DT + ptau[r];  // run time [s]
        lists[probot[j]].push(j); PL.maxLen = Math.max(PL.maxLen, poff[j + 1] - poff[j] + 1);
      }
      Object.assign(PL, {step: pstep, robot: probot, off: poff, pts: dequantise(ppts, q.lo, q.hi), t});
      PL.byRobot = lists.map(l => Int32Array.from(l));  // each in commit order: steps non-decreasing
    }
  }
  /** Robot i's latest plan committed at or before step s (-1: none yet). */
  function planAt(i, s) {
    const l = PL.byRobot[i];
    let a = 0, b = l.length;  // first entry committed after s
    while (a < b) { const m = (a + b) >> 1; if (PL.step[l[m]] <= s) a = m + 1; else b = m; }
    return a ? l[a - 1] : -1;
  }
  /** What is drawn of robot i's plan at step k: the plan from the current time to its end,
   * [[x, y(, z)], ...] [m], the first point interpolated at t = k dt; null when the robot has
   * no plan yet or its plan ended before t. */
  function planAhead(i) {
    const j = planAt(i, k);
    if (j < 0) return null;
    const a = PL.off[j], b = PL.off[j + 1], t = k * DT, T = PL.t, X = PL.pts;
    let c = a;
    while (c < b && T[c] < t) c++;
    if (c === b) return null;
    const pt = r => Array.from(X.subarray(r * DIM, r * DIM + DIM));
    const out = [];
    if (c > a && T[c] > T[c - 1]) {
      const f = (t - T[c - 1]) / (T[c] - T[c - 1]), p0 = pt(c - 1), p1 = pt(c);
      out.push(p0.map((x, d) => x + f * (p1[d] - x)));
    }
    for (let r = c; r < b; r++) out.push(pt(r));
    return out;
  }
  const clearanceOf = (k, i) => {
    const code = C[k * N + i];
    if (code === D.quant.levels) return Infinity;
    const [a, b] = D.quant.clearance;
    return a + code * (b - a) / (D.quant.levels - 1);
  };
  const speedOf = (k, i) => { let s = 0; for (let j = 0; j < DIM; j++) s += V[(k * N + i) * DIM + j] ** 2; return Math.sqrt(s); };
  const roleOf = (k, i) => ROLE ? ROLE_NAMES[ROLE[k * N + i]] : 'not recorded';
  /** Agent i's tilt at step k [deg]: the angle of its thrust axis from the vertical (null: no record). */
  const tiltOf = (k, i) => AX ? Math.acos(Math.max(-1, Math.min(1, AX[(k * N + i) * 3 + 2] / Math.hypot(...AX.subarray((k * N + i) * 3, (k * N + i) * 3 + 3))))) * 180 / Math.PI : null;

  // ------------------------------------------------------------------ state
  let k = 0, kf = 0, playing = false, rate = 1, view = DIM === 3 ? 'persp' : 'top', showTrails = true, showPlans = !!D.plans;
  let dirty = true, selected = -1, hovered = -1;
  const stats = {frames: 0, draws: 0, drawMs: 0, scaleSum: 0, readyMs: null, t0: performance.now()};
  const fmt = (x, n = 2) => (x === null || x === undefined || !isFinite(x)) ? 'n/a' : x.toFixed(n);

  // ------------------------------------------------------------------ top-down view
  const T = {s: 1, ox: 0, oy: 0, dpr: 1, bg: null};
  const lo = D.world.lo, hi = D.world.hi;
  const X = x => T.ox + (x - lo[0]) * T.s, Y = y => T.oy + (hi[1] - y) * T.s;
  const drawn = new Float32Array(N * 2);  // screen position of each agent as last drawn [css px]
  const axisTip = new Float32Array(N * 2);  // screen position of the end of each agent's thrust axis [css px]
  function layoutTop() {
    const w = stage.clientWidth, h = stage.clientHeight, dpr = window.devicePixelRatio || 1;
    top.width = Math.max(1, Math.round(w * dpr)); top.height = Math.max(1, Math.round(h * dpr));
    T.dpr = dpr;
    const m = 24, wx = hi[0] - lo[0], wy = hi[1] - lo[1];
    T.s = Math.min((w - 2 * m) / wx, (h - 2 * m) / wy);
    T.ox = (w - wx * T.s) / 2; T.oy = (h - wy * T.s) / 2;
    T.bg = document.createElement('canvas');
    T.bg.width = top.width; T.bg.height = top.height;
    const g = T.bg.getContext('2d');
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    g.fillStyle = '#fff'; g.fillRect(0, 0, w, h);
    g.strokeStyle = '#999'; g.lineWidth = 1; g.setLineDash(D.periodic ? [3, 3] : []);
    g.strokeRect(X(lo[0]), Y(hi[1]), wx * T.s, wy * T.s); g.setLineDash([]);
    for (const o of D.obstacles) {
      if (o.shell) continue;  // walls, ground and ceiling of a 3-D world box: its outline says it
      g.beginPath();
      if (o.t === 'circle' || o.t === 'cylinder' || o.t === 'sphere') g.arc(X(o.c[0]), Y(o.c[1]), o.r * T.s, 0, 2 * Math.PI);
      else o.v.forEach(([x, y], j) => j ? g.lineTo(X(x), Y(y)) : g.moveTo(X(x), Y(y)));
      g.closePath();
      g.globalAlpha = DIM === 3 ? 0.6 : 1; g.fillStyle = DIM === 3 ? SOLID : OBST_FACE; g.fill();
      g.globalAlpha = 1; g.strokeStyle = DIM === 3 ? SOLID_EDGE : OBST_EDGE; g.lineWidth = 0.8; g.stroke();
    }
    if (D.path.length) {  // the scene's path (HWVEM's waypoints), dash-dot as in the figures
      g.beginPath(); D.path.forEach(([x, y], j) => j ? g.lineTo(X(x), Y(y)) : g.moveTo(X(x), Y(y)));
      g.setLineDash([8, 3, 2, 3]); g.strokeStyle = PATH; g.lineWidth = 1.2; g.stroke(); g.setLineDash([]);
    }
    star(g, X(D.goal[0]), Y(D.goal[1]), 9);
    g.font = '11px system-ui, sans-serif'; g.fillStyle = '#555';
    g.fillText(`${fmt(hi[0] - lo[0], 0)} m x ${fmt(hi[1] - lo[1], 0)} m` + (DIM === 3 ? ' (seen from above)' : ''), X(lo[0]), Y(lo[1]) + 14);
    dirty = true;
  }
  function star(g, x, y, r) {
    g.beginPath();
    for (let j = 0; j < 10; j++) {
      const a = -Math.PI / 2 + j * Math.PI / 5, rr = j % 2 ? r * 0.45 : r;
      j ? g.lineTo(x + rr * Math.cos(a), y + rr * Math.sin(a)) : g.moveTo(x + rr * Math.cos(a), y + rr * Math.sin(a));
    }
    g.closePath(); g.fillStyle = GOAL; g.fill(); g.strokeStyle = '#000'; g.lineWidth = 1; g.stroke();
  }
  // half the periodic cell per axis [m]: a trail step longer than that is a wrap, not a move
  const halfCell = () => D.periodic ? [(hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2] : [Infinity, Infinity];
  function trailSteps(points = TRAIL_POINTS) {
    const len = Math.min(k, Math.round(TRAIL_SECONDS / DT));
    const stride = Math.max(1, Math.ceil(len / points)), out = [];
    for (let s = k; s >= k - len; s -= stride) out.push(s);
    return out;  // newest first
  }
  function groups() {  // agents by colour index at step k (counting sort)
    const n = D.palette.length, count = new Int32Array(n + 1), order = new Int32Array(N);
    for (let i = 0; i < N; i++) count[LAB[k * N + i] + 1]++;
    for (let c = 0; c < n; c++) count[c + 1] += count[c];
    const at = count.slice();
    for (let i = 0; i < N; i++) order[at[LAB[k * N + i]]++] = i;
    return {count, order};
  }
  function drawTop() {
    const w = top.width / T.dpr, h = top.height / T.dpr;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(T.bg, 0, 0);
    ctx.setTransform(T.dpr, 0, 0, T.dpr, 0, 0);
    const {count, order} = groups();
    const [hx, hy] = halfCell();
    if (showTrails) {
      const steps = trailSteps(), S = steps.length;
      ctx.lineWidth = N > 200 ? 1 : 1.5;
      for (let c = 0; c < D.palette.length; c++) {
        if (count[c + 1] === count[c]) continue;
        ctx.strokeStyle = D.palette[c];
        for (let b = 0; b < BANDS.length; b++) {
          const j0 = Math.floor((BANDS.length - 1 - b) * (S - 1) / BANDS.length);
          const j1 = Math.floor((BANDS.length - b) * (S - 1) / BANDS.length);
          if (j1 <= j0) continue;
          ctx.globalAlpha = BANDS[b];
          ctx.beginPath();
          for (let q = count[c]; q < count[c + 1]; q++) {
            const i = order[q];
            for (let j = j0; j < j1; j++) {
              const a = (steps[j] * N + i) * DIM, e = (steps[j + 1] * N + i) * DIM;
              if (Math.abs(P[a] - P[e]) > hx || Math.abs(P[a + 1] - P[e + 1]) > hy) continue;  // a wrap, not a move
              ctx.moveTo(X(P[a]), Y(P[a + 1])); ctx.lineTo(X(P[e]), Y(P[e + 1]));
            }
          }
          ctx.stroke();
        }
      }
      ctx.globalAlpha = 1;
    }
    if (showPlans) {  // each robot's plan ahead, in its sub-swarm's colour
      ctx.lineWidth = PLAN_WIDTH; ctx.globalAlpha = PLAN_ALPHA; ctx.setLineDash(PLAN_DASH);
      for (let i = 0; i < N; i++) {
        const line = planAhead(i);
        if (!line || line.length < 2) continue;
        ctx.beginPath(); line.forEach(([x, y], j) => j ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y)));
        ctx.strokeStyle = D.palette[LAB[k * N + i]]; ctx.stroke();
      }
      ctx.globalAlpha = 1; ctx.setLineDash([]);
    }
    const r = N > 300 ? 2.2 : N > 60 ? 3 : 4.5;
    for (let c = 0; c < D.palette.length; c++) {
      if (count[c + 1] === count[c]) continue;
      ctx.beginPath();
      for (let q = count[c]; q < count[c + 1]; q++) {
        const i = order[q], a = (k * N + i) * DIM, x = X(P[a]), y = Y(P[a + 1]);
        drawn[2 * i] = x; drawn[2 * i + 1] = y;
        ctx.moveTo(x + r, y); ctx.arc(x, y, r, 0, 2 * Math.PI);
      }
      ctx.fillStyle = D.palette[c]; ctx.fill();
    }
    if (AX) {  // thrust axes seen from above: a stick of AXIS_PX along body z, so its length is sin(tilt)
      ctx.beginPath();
      for (let i = 0; i < N; i++) {
        const b = (k * N + i) * 3, x = drawn[2 * i] + AXIS_PX * AX[b], y = drawn[2 * i + 1] - AXIS_PX * AX[b + 1];
        axisTip[2 * i] = x; axisTip[2 * i + 1] = y;
        ctx.moveTo(drawn[2 * i], drawn[2 * i + 1]); ctx.lineTo(x, y);
      }
      ctx.strokeStyle = AXIS_COLOR; ctx.lineWidth = N > 300 ? 1 : 1.5; ctx.stroke();
    }
    if (ROLE) {  // leader: thick black ring; subleaders: thin ring
      for (const [code, width, rr] of [[1, 1.2, r + 2], [2, 2.2, r + 3.5]]) {
        ctx.beginPath();
        for (let i = 0; i < N; i++) if (ROLE[k * N + i] === code) { ctx.moveTo(drawn[2 * i] + rr, drawn[2 * i + 1]); ctx.arc(drawn[2 * i], drawn[2 * i + 1], rr, 0, 2 * Math.PI); }
        ctx.strokeStyle = '#000'; ctx.lineWidth = width; ctx.stroke();
      }
    }
    for (const [i, col] of [[hovered, '#888'], [selected, '#d00']]) {
      if (i < 0) continue;
      ctx.beginPath(); ctx.arc(drawn[2 * i], drawn[2 * i + 1], r + 6, 0, 2 * Math.PI);
      ctx.strokeStyle = col; ctx.lineWidth = 2; ctx.stroke();
    }
  }
  function pickTop(mx, my) {
    let best = -1, bd = 100;  // within 10 px
    for (let i = 0; i < N; i++) {
      const d = (drawn[2 * i] - mx) ** 2 + (drawn[2 * i + 1] - my) ** 2;
      if (d < bd) { bd = d; best = i; }
    }
    return best;
  }

  // ------------------------------------------------------------------ perspective view (three.js)
  let G = null, gPromise = null;
  function libSource(name) {
    if (window.SWARMNAV_LIBS && window.SWARMNAV_LIBS[name]) return window.SWARMNAV_LIBS[name];
    return $('lib-' + name).textContent;
  }
  async function loadThree() {
    const url = s => URL.createObjectURL(new Blob([s], {type: 'text/javascript'}));
    const core = url(libSource('core'));
    const mod = libSource('three'), orbit = libSource('orbit');
    if (!mod.includes('"./three.core.min.js"') || !orbit.includes("from 'three'")) throw new Error('swarmnav viewer: unexpected three.js import lines');
    const three = url(mod.replaceAll('"./three.core.min.js"', JSON.stringify(core)));
    const THREE = await import(three);
    const {OrbitControls} = await import(url(orbit.replace("from 'three'", 'from ' + JSON.stringify(three))));
    return {THREE, OrbitControls};
  }
  function initPersp() {
    if (!gPromise) gPromise = loadThree().then(({THREE, OrbitControls}) => { G = buildScene(THREE, OrbitControls); dirty = true; return G; });
    return gPromise;
  }
  function buildScene(THREE, OrbitControls) {
    THREE.Object3D.DEFAULT_UP.set(0, 0, 1);
    // A large swarm is drawn more cheaply in perspective (arrows of 3 facets instead of 10,
    // solids of fewer facets, half the trail points, no multisampling): on a software
    // rasteriser (SwiftShader, a machine without a GPU) each of these costs frames with 1000
    // agents. No page keeps its drawing buffer (screenshots capture it all the same), and the
    // canvas is opaque, so the compositor need not blend it.
    const renderer = new THREE.WebGLRenderer({antialias: !LARGE, alpha: false, preserveDrawingBuffer: false});
    renderer.setPixelRatio((window.devicePixelRatio || 1) * RES.scale);
    renderer.setClearColor(0xf4f6f8);
    persp.appendChild(renderer.domElement);
    const scene = new THREE.Scene();
    scene.add(new THREE.HemisphereLight(0xffffff, 0x8890a0, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6); sun.position.set(-0.35, -0.55, 0.76); scene.add(sun);
    const z0 = DIM === 3 ? lo[2] : 0, altitude = DIM === 3 ? null : D.altitude;
    const zTop = DIM === 3 ? hi[2] : Math.max(D.slab_height, altitude + 2);
    const ext = [hi[0] - lo[0], hi[1] - lo[1], zTop - z0], diag = Math.hypot(...ext);
    const centre = new THREE.Vector3((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, DIM === 3 ? (z0 + zTop) / 2 : altitude / 2);
    // ground and the world box outline
    // Surfaces are shaded once, here, from their normals (the light of the matplotlib figures,
    // draw3d.LIGHT: 0.62 + 0.38 max(0, n.l)), and drawn unlit: per-pixel lighting cost a software
    // rasteriser 12 % of its frames with 1000 agents (13.9 against 15.7 fps, mean of 4
    // alternating runs of bench_viewer.py's page).
    const LIGHT = new THREE.Vector3(-0.35, -0.55, 0.76).normalize();
    const shade = (normals, color) => {
      const c = new THREE.Color(color), out = new Float32Array(normals.length);
      for (let i = 0; i < normals.length; i += 3) {
        const f = 0.62 + 0.38 * Math.max(0, normals[i] * LIGHT.x + normals[i + 1] * LIGHT.y + normals[i + 2] * LIGHT.z);
        out[i] = c.r * f; out[i + 1] = c.g * f; out[i + 2] = c.b * f;
      }
      return out;
    };
    const baked = geo => {  // a non-indexed copy with flat normals and its shade as vertex colours
      const g = geo.index ? geo.toNonIndexed() : geo.clone();
      g.computeVertexNormals();
      g.setAttribute('color', new THREE.BufferAttribute(shade(g.attributes.normal.array, 0xffffff), 3));
      return g;
    };
    const ground = new THREE.Mesh(new THREE.PlaneGeometry(ext[0], ext[1]), new THREE.MeshBasicMaterial({color: 0xdde1e6}));
    ground.position.set(centre.x, centre.y, z0 - 0.01); scene.add(ground);
    const boxEdges = (a, b, color, opacity) => {
      const geo = new THREE.EdgesGeometry(new THREE.BoxGeometry(b[0] - a[0], b[1] - a[1], b[2] - a[2]));
      const l = new THREE.LineSegments(geo, new THREE.LineBasicMaterial({color, transparent: opacity < 1, opacity}));
      l.position.set((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2); return l;
    };
    if (DIM === 3) scene.add(boxEdges(lo, hi, 0x999999, 0.6));
    // obstacles: a 3-D run's solids; a planar run's obstacles as light-grey slabs (HES Figure A1)
    const solidColor = DIM === 3 ? SOLID : 0xd3d6db;
    const solidMat = new THREE.MeshBasicMaterial({vertexColors: true, transparent: DIM === 3, opacity: DIM === 3 ? 0.62 : 1, depthWrite: DIM !== 3});
    const edgeMat = new THREE.LineBasicMaterial({color: SOLID_EDGE, transparent: true, opacity: 0.7});
    // every obstacle goes into one mesh and one set of edges: two draw calls for the whole
    // scene however many obstacles it has (a forest of hundreds of trees stays two calls)
    const solidPos = [], solidNrm = [], edgePos = [], M = new THREE.Matrix4(), Rx = new THREE.Matrix4();
    const addSolid = (geo, x, y, z, rotX) => {
      M.makeTranslation(x, y, z); if (rotX) M.multiply(Rx.makeRotationX(Math.PI / 2));
      const edges = new THREE.EdgesGeometry(geo, 30).applyMatrix4(M);
      const g = (geo.index ? geo.toNonIndexed() : geo).applyMatrix4(M);
      solidPos.push(g.attributes.position.array); solidNrm.push(g.attributes.normal.array); edgePos.push(edges.attributes.position.array);
    };
    const cat = arrays => {
      const out = new Float32Array(arrays.reduce((n, a) => n + a.length, 0)); let o = 0;
      for (const a of arrays) { out.set(a, o); o += a.length; }
      return out;
    };
    for (const o of D.obstacles) {
      const [za, zb] = o.z || [0, D.slab_height];
      if (o.shell) {
        const a = [Math.max(o.v[0][0], lo[0]), Math.max(o.v[0][1], lo[1]), Math.max(za, lo[2])];
        const b = [Math.min(o.v[2][0], hi[0]), Math.min(o.v[2][1], hi[1]), Math.min(zb, hi[2])];
        scene.add(boxEdges(a, b, 0x59606b, 0.6)); continue;
      }
      if (o.t === 'sphere') addSolid(new THREE.SphereGeometry(o.r, LARGE ? 16 : 24, LARGE ? 8 : 12), o.c[0], o.c[1], o.c[2]);
      else if (o.t === 'circle' || o.t === 'cylinder') addSolid(new THREE.CylinderGeometry(o.r, o.r, zb - za, LARGE ? 16 : 28), o.c[0], o.c[1], (za + zb) / 2, true);
      else {
        const shape = new THREE.Shape(o.v.map(([x, y]) => new THREE.Vector2(x, y)));
        addSolid(new THREE.ExtrudeGeometry(shape, {depth: zb - za, bevelEnabled: false}), 0, 0, za);
      }
    }
    if (solidPos.length) {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(cat(solidPos), 3));
      g.setAttribute('normal', new THREE.BufferAttribute(cat(solidNrm), 3));
      g.setAttribute('color', new THREE.BufferAttribute(shade(g.attributes.normal.array, solidColor), 3));
      const e = new THREE.BufferGeometry(); e.setAttribute('position', new THREE.BufferAttribute(cat(edgePos), 3));
      scene.add(new THREE.Mesh(g, solidMat), new THREE.LineSegments(e, edgeMat));
    }
    // goal: a yellow star (with a drop line to the ground)
    const gz = DIM === 3 ? D.goal[2] : altitude, rs = Math.max(0.8, 0.02 * Math.max(ext[0], ext[1]));
    const starShape = new THREE.Shape();
    for (let j = 0; j < 10; j++) {
      const a = Math.PI / 2 + j * Math.PI / 5, rr = j % 2 ? rs * 0.45 : rs;
      j ? starShape.lineTo(rr * Math.cos(a), rr * Math.sin(a)) : starShape.moveTo(rr * Math.cos(a), rr * Math.sin(a));
    }
    const starGeo = new THREE.ExtrudeGeometry(starShape, {depth: rs * 0.25, bevelEnabled: false});
    const goal = new THREE.Mesh(starGeo, new THREE.MeshLambertMaterial({color: GOAL, emissive: 0x554400}));
    goal.rotation.x = Math.PI / 2; goal.position.set(D.goal[0], D.goal[1], gz); scene.add(goal);
    const gl = new THREE.LineSegments(new THREE.EdgesGeometry(starGeo), new THREE.LineBasicMaterial({color: 0x000000}));
    gl.rotation.copy(goal.rotation); gl.position.copy(goal.position); scene.add(gl);
    const drop = new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(D.goal[0], D.goal[1], z0), new THREE.Vector3(D.goal[0], D.goal[1], gz)]);
    const dropLine = new THREE.Line(drop, new THREE.LineDashedMaterial({color: 0x555555, dashSize: 0.5, gapSize: 0.4}));
    dropLine.computeLineDistances(); scene.add(dropLine);
    if (D.path.length) {  // the scene's path, at the flight altitude of a planar run
      const pts = D.path.map(p => new THREE.Vector3(p[0], p[1], DIM === 3 ? p[2] : altitude));
      const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(pts),
                                  new THREE.LineDashedMaterial({color: PATH, dashSize: 1.2, gapSize: 0.6}));
      line.computeLineDistances(); scene.add(line);
    }
    // agents: arrows along their heading, coloured by sub-swarm
    const a = LARGE ? Math.max(0.35, 0.006 * Math.max(ext[0], ext[1])) : Math.max(0.6, 0.014 * Math.max(ext[0], ext[1]));
    // All N arrows are one mesh whose vertices drawPersp places each frame: a software
    // rasteriser (SwiftShader) pays for each instance of an InstancedMesh whatever its
    // triangles (1000 agents: 40 ms of CPU per frame instanced, 25 ms as one mesh).
    const cone = new THREE.ConeGeometry(a * 0.38, a, LARGE ? 3 : 10); cone.rotateZ(-Math.PI / 2);  // along +x
    const tpl = baked(cone), tplPos = tpl.attributes.position.array, nv = tplPos.length / 3;
    const tplShade = new Float32Array(nv);
    let apex = 0, base = -1;  // the tip and the centre of the base: where an arrow is and points
    for (let v = 0; v < nv; v++) {
      tplShade[v] = tpl.attributes.color.array[3 * v];
      if (tplPos[3 * v] > tplPos[3 * apex]) apex = v;
      if (base < 0 && Math.abs(tplPos[3 * v] + a / 2) < 1e-6 * a && Math.abs(tplPos[3 * v + 1]) < 1e-6 * a && Math.abs(tplPos[3 * v + 2]) < 1e-6 * a) base = v;
    }
    const aGeo = new THREE.BufferGeometry();
    aGeo.setAttribute('position', new THREE.BufferAttribute(new Float32Array(N * nv * 3), 3).setUsage(THREE.DynamicDrawUsage));
    aGeo.setAttribute('color', new THREE.BufferAttribute(new Float32Array(N * nv * 3), 3).setUsage(THREE.DynamicDrawUsage));
    const agents = new THREE.Mesh(aGeo, new THREE.MeshBasicMaterial({vertexColors: true}));
    agents.frustumCulled = false; scene.add(agents);
    const arrow = {tplPos, tplShade, nv, apex, base};
    const ring = new THREE.Mesh(new THREE.TorusGeometry(a * 0.9, a * 0.09, 6, 24), new THREE.MeshBasicMaterial({color: 0x000000}));
    ring.visible = false; scene.add(ring);
    // roles, when recorded: a thin black ring round each subleader, a thick one round the leader
    const roleRings = [null, [0.7, 0.05], [0.8, 0.13]].map(r => {
      if (!r || !ROLE) return null;
      const m = new THREE.InstancedMesh(new THREE.TorusGeometry(a * r[0], a * r[1], 5, 20), new THREE.MeshBasicMaterial({color: 0x111111}), N);
      m.count = 0; m.frustumCulled = false; scene.add(m); return m;
    });
    // thrust axes of a quadrotor run: one set of line segments, from each agent along its body z
    // axis, 2 arrow lengths long, rewritten in place each frame (one draw call for all agents)
    let axes = null;
    if (AX) {
      const xGeo = new THREE.BufferGeometry();
      xGeo.setAttribute('position', new THREE.BufferAttribute(new Float32Array(N * 6), 3).setUsage(THREE.DynamicDrawUsage));
      axes = new THREE.LineSegments(xGeo, new THREE.LineBasicMaterial({color: AXIS_COLOR}));
      axes.frustumCulled = false; axes.userData.length = 2 * a; scene.add(axes);
    }
    // trails: fading segments (RGBA vertex colours)
    const maxSeg = N * TRAIL_POINTS;
    const tPos = new Float32Array(maxSeg * 6), tCol = new Float32Array(maxSeg * 8);
    const tGeo = new THREE.BufferGeometry();
    tGeo.setAttribute('position', new THREE.BufferAttribute(tPos, 3).setUsage(THREE.DynamicDrawUsage));
    tGeo.setAttribute('color', new THREE.BufferAttribute(tCol, 4).setUsage(THREE.DynamicDrawUsage));
    const trails = new THREE.LineSegments(tGeo, new THREE.LineBasicMaterial({vertexColors: true, transparent: true, depthWrite: false}));
    trails.frustumCulled = false; scene.add(trails);
    // committed plans: dashed line segments in each agent's colour, rewritten in place like the
    // trails (the dashes run on the length along each plan, pDist [m])
    const maxPlan = D.plans ? N * PL.maxLen : 1, dash = 0.012 * Math.max(ext[0], ext[1]);
    const pPos = new Float32Array(maxPlan * 6), pCol = new Float32Array(maxPlan * 6), pDist = new Float32Array(maxPlan * 2);
    const pGeo = new THREE.BufferGeometry();
    pGeo.setAttribute('position', new THREE.BufferAttribute(pPos, 3).setUsage(THREE.DynamicDrawUsage));
    pGeo.setAttribute('color', new THREE.BufferAttribute(pCol, 3).setUsage(THREE.DynamicDrawUsage));
    pGeo.setAttribute('lineDistance', new THREE.BufferAttribute(pDist, 1).setUsage(THREE.DynamicDrawUsage));
    const planLines = new THREE.LineSegments(pGeo, new THREE.LineDashedMaterial({vertexColors: true, transparent: true, opacity: PLAN_ALPHA,
                                                                                 depthWrite: false, dashSize: 2 * dash, gapSize: dash}));
    planLines.frustumCulled = false; scene.add(planLines);
    const camera = new THREE.PerspectiveCamera(40, 1, Math.max(0.05, diag / 2000), diag * 20);
    // the default camera of the matplotlib 3-D figures (elevation 35, azimuth -60 deg); a planar
    // run from higher up (50 deg), to see between its slabs
    const el = (DIM === 3 ? 35 : 50) * Math.PI / 180, az = -60 * Math.PI / 180, R = 0.4 * diag / Math.tan(20 * Math.PI / 180);
    camera.position.set(centre.x + R * Math.cos(el) * Math.cos(az), centre.y + R * Math.cos(el) * Math.sin(az), centre.z + R * Math.sin(el));
    const controls = new OrbitControls(camera, renderer.domElement);
    controls.target.copy(centre); controls.update();
    controls.addEventListener('change', () => { dirty = true; });
    const palette = D.palette.map(c => new THREE.Color(c));
    const g = {THREE, renderer, scene, camera, controls, agents, arrow, axes, trails, tGeo, tPos, tCol, pGeo, pPos, pCol, pDist, palette, ring, roleRings, altitude,
               m: new THREE.Matrix4(), q: new THREE.Quaternion(), p: new THREE.Vector3(), s: new THREE.Vector3(1, 1, 1),
               ux: new THREE.Vector3(1, 0, 0), u: new THREE.Vector3(), ray: new THREE.Raycaster(), ptr: new THREE.Vector2()};
    layoutPersp(g);
    return g;
  }
  function layoutPersp(g) {
    const w = stage.clientWidth, h = stage.clientHeight;
    g.renderer.setSize(w, h); g.camera.aspect = w / Math.max(h, 1); g.camera.updateProjectionMatrix(); dirty = true;
  }
  const zOf = (k, i) => DIM === 3 ? P[(k * N + i) * 3 + 2] : G.altitude;
  function drawPersp() {
    const g = G, {m, q, p, s, u, ux} = g, aGeo = g.agents.geometry, {tplPos: tp, tplShade, nv} = g.arrow;
    const pos = aGeo.attributes.position.array, cols = aGeo.attributes.color.array;
    for (let i = 0; i < N; i++) {
      const a = (k * N + i) * DIM;
      // heading: the velocity's direction, or the last one before this step for an agent at rest
      // (looked up to 500 steps back; +x for one that has not moved yet)
      let b = a, sp = 0;
      for (let kk = k; kk >= Math.max(0, k - 500); kk--) {
        b = (kk * N + i) * DIM;
        sp = Math.hypot(V[b], V[b + 1], DIM === 3 ? V[b + 2] : 0);
        if (sp > 1e-6) break;
      }
      if (sp > 1e-6) u.set(V[b] / sp, V[b + 1] / sp, DIM === 3 ? V[b + 2] / sp : 0); else u.set(1, 0, 0);
      q.setFromUnitVectors(ux, u);
      const e = m.makeRotationFromQuaternion(q).elements, px = P[a], py = P[a + 1], pz = zOf(k, i), col = g.palette[LAB[k * N + i]];
      for (let v = 0, o = i * nv * 3; v < nv; v++, o += 3) {
        const x = tp[3 * v], y = tp[3 * v + 1], z = tp[3 * v + 2], f = tplShade[v];
        pos[o] = px + e[0] * x + e[4] * y + e[8] * z; pos[o + 1] = py + e[1] * x + e[5] * y + e[9] * z; pos[o + 2] = pz + e[2] * x + e[6] * y + e[10] * z;
        cols[o] = col.r * f; cols[o + 1] = col.g * f; cols[o + 2] = col.b * f;
      }
    }
    aGeo.attributes.position.needsUpdate = true; aGeo.attributes.color.needsUpdate = true;
    if (g.axes) {  // each stick from the agent (its arrow's centre) along its thrust axis
      const xp = g.axes.geometry.attributes.position.array, len = g.axes.userData.length;
      for (let i = 0; i < N; i++) {
        const a = (k * N + i) * DIM, b = (k * N + i) * 3, o = 6 * i, pz = zOf(k, i);
        xp[o] = P[a]; xp[o + 1] = P[a + 1]; xp[o + 2] = pz;
        xp[o + 3] = P[a] + len * AX[b]; xp[o + 4] = P[a + 1] + len * AX[b + 1]; xp[o + 5] = pz + len * AX[b + 2];
      }
      g.axes.geometry.attributes.position.needsUpdate = true;
    }
    if (ROLE) {
      q.identity();
      for (const code of [1, 2]) {
        const rings = g.roleRings[code]; let c = 0;
        for (let i = 0; i < N; i++) if (ROLE[k * N + i] === code) {
          const a = (k * N + i) * DIM; p.set(P[a], P[a + 1], zOf(k, i)); rings.setMatrixAt(c++, m.compose(p, q, s));
        }
        rings.count = c; rings.instanceMatrix.needsUpdate = true;
      }
    }
    let n = 0;
    if (showTrails) {
      const steps = trailSteps(LARGE ? TRAIL_POINTS / 2 : TRAIL_POINTS), S = steps.length, [hx, hy] = halfCell();
      for (let i = 0; i < N; i++) {
        const col = g.palette[LAB[k * N + i]];
        for (let j = 0; j + 1 < S; j++) {
          const a = (steps[j] * N + i) * DIM, e = (steps[j + 1] * N + i) * DIM;
          if (Math.abs(P[a] - P[e]) > hx || Math.abs(P[a + 1] - P[e + 1]) > hy) continue;
          const o = n * 6, c = n * 8, alpha = 0.75 * (1 - j / (S - 1));
          g.tPos[o] = P[a]; g.tPos[o + 1] = P[a + 1]; g.tPos[o + 2] = zOf(steps[j], i);
          g.tPos[o + 3] = P[e]; g.tPos[o + 4] = P[e + 1]; g.tPos[o + 5] = zOf(steps[j + 1], i);
          for (const [off, al] of [[0, alpha], [4, 0.75 * (1 - (j + 1) / (S - 1))]]) {
            g.tCol[c + off] = col.r; g.tCol[c + off + 1] = col.g; g.tCol[c + off + 2] = col.b; g.tCol[c + off + 3] = al;
          }
          n++;
        }
      }
    }
    g.tGeo.setDrawRange(0, 2 * n);
    g.tGeo.attributes.position.needsUpdate = true; g.tGeo.attributes.color.needsUpdate = true;
    n = 0;
    if (showPlans) {
      for (let i = 0; i < N; i++) {
        const line = planAhead(i), col = g.palette[LAB[k * N + i]];
        if (!line) continue;
        for (let j = 0, len = 0; j + 1 < line.length; j++, n++) {
          for (const [o, pt] of [[n * 6, line[j]], [n * 6 + 3, line[j + 1]]]) {
            g.pPos[o] = pt[0]; g.pPos[o + 1] = pt[1]; g.pPos[o + 2] = DIM === 3 ? pt[2] : g.altitude;
            g.pCol[o] = col.r; g.pCol[o + 1] = col.g; g.pCol[o + 2] = col.b;
          }
          g.pDist[2 * n] = len; len += Math.hypot(...line[j + 1].map((x, d) => x - line[j][d])); g.pDist[2 * n + 1] = len;
        }
      }
    }
    g.pGeo.setDrawRange(0, 2 * n);
    for (const a of ['position', 'color', 'lineDistance']) g.pGeo.attributes[a].needsUpdate = true;
    const pick = selected >= 0 ? selected : hovered;
    g.ring.visible = pick >= 0;
    if (pick >= 0) { const a = (k * N + pick) * DIM; g.ring.position.set(P[a], P[a + 1], zOf(k, pick)); }
    g.renderer.render(g.scene, g.camera);
  }
  /** Agent i's arrow as drawn, read back from the mesh's vertices: [midpoint of tip and base
   * centre (where the agent is) [m], unit vector from base to tip (its heading)]. */
  function arrowAt(i) {
    const pos = G.agents.geometry.attributes.position.array, {nv, apex, base} = G.arrow;
    const t = (i * nv + apex) * 3, b = (i * nv + base) * 3, d = [0, 1, 2].map(j => pos[t + j] - pos[b + j]);
    const n = Math.hypot(...d);
    return [[0, 1, 2].map(j => (pos[t + j] + pos[b + j]) / 2), d.map(x => x / n)];
  }
  function pickPersp(mx, my) {
    const g = G; g.ptr.set(mx / stage.clientWidth * 2 - 1, -my / stage.clientHeight * 2 + 1);
    g.ray.setFromCamera(g.ptr, g.camera);
    g.agents.geometry.computeBoundingSphere();  // the raycast tests it first: it must hold the agents of this step
    const hit = g.ray.intersectObject(g.agents, false)[0];
    return hit ? Math.floor(hit.faceIndex * 3 / g.arrow.nv) : -1;
  }

  // ------------------------------------------------------------------ strip chart, timeline
  const CH = {bg: null, pad: 8};
  const xOfStep = s => CH.pad + (chart.clientWidth - 2 * CH.pad) * (K ? s / K : 0);
  function layoutChart() {
    const w = chart.clientWidth, h = chart.clientHeight, dpr = window.devicePixelRatio || 1;
    chart.width = Math.round(w * dpr); chart.height = Math.round(h * dpr);
    const bg = CH.bg = document.createElement('canvas'); bg.width = chart.width; bg.height = chart.height;
    const g = bg.getContext('2d'); g.setTransform(dpr, 0, 0, dpr, 0, 0);
    g.fillStyle = '#fff'; g.fillRect(0, 0, w, h);
    const y0 = h - 14, y1 = 14;
    let cmax = 2 * D.d_safe, cmin = 0;
    for (let s = 0; s <= K; s++) if (isFinite(MINC[s])) { cmax = Math.max(cmax, MINC[s]); cmin = Math.min(cmin, MINC[s]); }
    const yc = c => y0 - (c - cmin) / (cmax - cmin) * (y0 - y1);
    let nmax = 1; for (let s = 0; s <= K; s++) nmax = Math.max(nmax, NSUB[s]);
    const yn = n => y0 - n / (nmax + 1) * (y0 - y1);
    g.strokeStyle = '#ddd'; g.lineWidth = 1; g.beginPath(); g.moveTo(xOfStep(0), y0); g.lineTo(xOfStep(K), y0); g.stroke();
    g.strokeStyle = '#888'; g.setLineDash([5, 4]); g.beginPath(); g.moveTo(xOfStep(0), yc(D.d_safe)); g.lineTo(xOfStep(K), yc(D.d_safe)); g.stroke(); g.setLineDash([]);
    g.strokeStyle = '#1f77b4'; g.lineWidth = 1.3; g.beginPath();
    for (let s = 0, prev = 0; s <= K; s++) { const x = xOfStep(s), y = yn(NSUB[s]); s ? (g.lineTo(x, prev), g.lineTo(x, y)) : g.moveTo(x, y); prev = y; }
    g.stroke();
    g.strokeStyle = '#d62728'; g.lineWidth = 1.3; g.beginPath(); let pen = false;
    for (let s = 0; s <= K; s++) { if (!isFinite(MINC[s])) { pen = false; continue; } const x = xOfStep(s), y = yc(MINC[s]); pen ? g.lineTo(x, y) : g.moveTo(x, y); pen = true; }
    g.stroke();
    g.font = '11px system-ui, sans-serif';
    g.fillStyle = '#d62728'; g.fillText(`min clearance [m] (${fmt(cmin, 1)} to ${fmt(cmax, 1)})`, CH.pad + 2, 11);
    g.fillStyle = '#777'; g.fillText(`d_safe = ${D.d_safe} m`, CH.pad + 190, 11);
    g.fillStyle = '#1f77b4'; g.fillText(`sub-swarms (0 to ${nmax + 1})`, CH.pad + 290, 11);
    g.fillStyle = '#555'; g.fillText(`t = 0 to ${fmt(K * DT, 1)} s`, w - CH.pad - 110, h - 2);
    if (!MINC.some(isFinite)) { g.fillStyle = '#999'; g.fillText('no obstacles: clearance is infinite', w / 2 - 80, h / 2); }
  }
  function drawChart() {
    const dpr = window.devicePixelRatio || 1;
    cctx.setTransform(1, 0, 0, 1, 0, 0); cctx.drawImage(CH.bg, 0, 0);
    cctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const x = xOfStep(k); cctx.strokeStyle = '#000'; cctx.lineWidth = 1; cctx.beginPath(); cctx.moveTo(x, 12); cctx.lineTo(x, chart.clientHeight - 12); cctx.stroke();
  }
  function marks() {
    const box = $('marks');
    for (const e of D.events) {
      const b = document.createElement('button'), s = Math.min(e.step + 1, K);
      const kind = {'split': 'split', 'merge': 'merge', 'llm': 'llm', 'llm fallback': 'fallback'}[e.action] || 'other';
      b.className = kind;
      b.textContent = {split: '\u25B2', merge: '\u25C7', llm: '\u2022', fallback: '\u00D7'}[kind] || '\u25CF';
      b.style.left = (K ? 100 * s / K : 0) + '%';
      b.title = `${e.action} at step ${e.step} (t = ${fmt(e.step * DT, 1)} s)` + (e.source ? `, ${e.source}` : '') + (e.reason ? `: ${e.reason}` : '');
      b.addEventListener('click', () => { pause(); seek(s); });
      box.appendChild(b);
    }
  }

  // ------------------------------------------------------------------ adaptive resolution
  // While the perspective view plays, drawn frames that take longer than the budget (1/30 s,
  // mean of 8) lower the drawing buffer's resolution one step (1, 0.75, 0.5 of the page's pixel
  // ratio per axis; the browser scales the picture up to the canvas) until the next pause; a
  // pause, a step or a seek draws at full resolution. Off ('full'): always full resolution.
  const RES = {adaptive: true, scale: 1, budget: 1000 / 30, steps: [1, 0.75, 0.5], recent: []};
  function setScale(x) {
    if (x === RES.scale) return;
    RES.scale = x; RES.recent.length = 0;
    if (G) { G.renderer.setPixelRatio((window.devicePixelRatio || 1) * x); dirty = true; }
  }
  function adapt(ms) {  // ms: how long the last drawn frame took, to the next frame [ms]
    RES.recent.push(ms);
    if (RES.recent.length < 8) return;  // the mean of 8 frames, after each change anew
    const mean = RES.recent.reduce((a, b) => a + b) / RES.recent.length, j = RES.steps.indexOf(RES.scale);
    RES.recent.shift();
    if (mean > RES.budget && j + 1 < RES.steps.length) setScale(RES.steps[j + 1]);
  }
  function setResolution(mode, budget) {
    RES.adaptive = mode !== 'full'; $('adaptive').checked = RES.adaptive;
    if (budget) RES.budget = budget;
    if (!RES.adaptive) setScale(1);
  }

  // ------------------------------------------------------------------ controls, loop
  function seek(s) { k = Math.max(0, Math.min(K, Math.round(s))); kf = k; scrub.value = k; dirty = true; return k; }
  function play() { if (k >= K) seek(0); playing = true; playBtn.innerHTML = '&#10074;&#10074;'; }
  function pause() { playing = false; setScale(1); RES.recent.length = 0; playBtn.innerHTML = '&#9654;'; }
  function setView(v) {
    view = v; viewSel.value = v; top.hidden = v !== 'top'; persp.hidden = v !== 'persp'; dirty = true;
    return v === 'persp' ? initPersp().then(() => { layoutPersp(G); render(); }) : Promise.resolve(render());
  }
  function render() {
    const t = performance.now();
    if (view === 'persp') { if (!G) return; drawPersp(); } else drawTop();
    drawChart();
    const tip = hovered >= 0 ? hovered : selected;
    if (tip >= 0) showTip(tip);
    $('clock').textContent = `step ${k} / ${K}   t = ${fmt(k * DT, 1)} s   sub-swarms ${NSUB[k]}`;
    stats.draws++; stats.drawMs += performance.now() - t; stats.scaleSum += view === 'persp' ? RES.scale : 1; dirty = false;
  }
  let lastT = null, drewLast = false, tipXY = [0, 0];
  function frame(t) {
    stats.frames++;
    if (drewLast && playing && view === 'persp' && RES.adaptive) adapt(t - lastT);
    if (playing) {
      if (lastT !== null) { kf = Math.min(K, kf + rate * (t - lastT) / 1000 / DT); if (Math.floor(kf) !== k) { k = Math.floor(kf); scrub.value = k; dirty = true; } }
      if (k >= K) pause();
    }
    lastT = t; drewLast = dirty;
    if (dirty) render();
    requestAnimationFrame(frame);
  }
  function showTip(i) {
    const c = clearanceOf(k, i), ids = D.label_ids[LAB[k * N + i]];
    tip.textContent = `agent ${i}\nrole: ${roleOf(k, i)}\nsub-swarm: ${ids}\nspeed: ${fmt(speedOf(k, i))} m/s\nclearance: ${isFinite(c) ? fmt(c) + ' m' : 'no obstacle'}` +
      (AX ? `\ntilt: ${fmt(tiltOf(k, i), 1)} deg` : '');
    tip.hidden = false; tip.style.left = (tipXY[0] + 14) + 'px'; tip.style.top = (tipXY[1] + 10) + 'px';
  }
  const pick = (x, y) => view === 'persp' ? (G ? pickPersp(x, y) : -1) : pickTop(x, y);
  stage.addEventListener('mousemove', ev => {
    const r = stage.getBoundingClientRect(); tipXY = [ev.clientX - r.left, ev.clientY - r.top];
    const i = pick(tipXY[0], tipXY[1]);
    if (i !== hovered) { hovered = i; dirty = true; if (i < 0 && selected < 0) tip.hidden = true; }
  });
  stage.addEventListener('click', ev => {
    const r = stage.getBoundingClientRect(); tipXY = [ev.clientX - r.left, ev.clientY - r.top];
    selected = pick(tipXY[0], tipXY[1]); if (selected < 0) tip.hidden = true; dirty = true;
  });
  playBtn.addEventListener('click', () => playing ? pause() : play());
  $('back').addEventListener('click', () => { pause(); seek(k - 1); });
  $('fwd').addEventListener('click', () => { pause(); seek(k + 1); });
  scrub.addEventListener('input', () => { pause(); seek(+scrub.value); });
  chart.addEventListener('click', ev => { pause(); const r = chart.getBoundingClientRect(); seek((ev.clientX - r.left - CH.pad) / (r.width - 2 * CH.pad) * K); });
  viewSel.addEventListener('change', () => setView(viewSel.value));
  $('trails').addEventListener('change', ev => { showTrails = ev.target.checked; dirty = true; });
  if (D.plans) $('plans').addEventListener('change', ev => { showPlans = ev.target.checked; dirty = true; });
  else $('plans-box').remove();  // nothing recorded: no toggle
  $('adaptive').addEventListener('change', ev => setResolution(ev.target.checked ? 'adaptive' : 'full'));
  const RATES = [0.25, 0.5, 1, 2, 5, 10, 20, 50, 100];
  for (const x of RATES) speedSel.add(new Option(`${x}x`, x));
  speedSel.addEventListener('change', () => { rate = +speedSel.value; });
  document.addEventListener('keydown', ev => {
    if (ev.target.tagName === 'SELECT') return;
    const n = ev.shiftKey ? 10 : 1;
    if (ev.key === ' ') { ev.preventDefault(); playing ? pause() : play(); }
    else if (ev.key === 'ArrowRight') { ev.preventDefault(); pause(); seek(k + n); }
    else if (ev.key === 'ArrowLeft') { ev.preventDefault(); pause(); seek(k - n); }
    else if (ev.key === 'Home') { pause(); seek(0); }
    else if (ev.key === 'End') { pause(); seek(K); }
  });
  new ResizeObserver(() => { if (!P) return; layoutTop(); layoutChart(); if (G) layoutPersp(G); dirty = true; }).observe(document.body);

  function legend() {
    const parts = [];
    if (D.palette.length <= 8) D.palette.forEach((c, j) => parts.push(`<span class="sw" style="background:${c}"></span>sub-swarm ${D.label_ids[j]}`));
    if (ROLE) parts.push('<span class="sw" style="border:2px solid #000"></span>leader (thick ring), subleader (ring)');
    if (D.plans) parts.push(`&nbsp; - - plan ahead (${D.plans.count} committed)`);
    if (D.thrust) parts.push(`&nbsp; <span class="sw" style="width:14px;height:0;border-radius:0;border-top:2px solid ${AXIS_COLOR}"></span>thrust axis (body z)`);
    $('legend').innerHTML = parts.join(' ');
    const m = D.metrics;
    $('summary').textContent = `N = ${N}, K = ${K}, dt = ${DT} s` + ('Y' in m ? `  ·  Y = ${fmt(m.Y, 0)}  R_goal = ${fmt(m.R_goal)}  E_mean = ${fmt(m.E_mean)} m  R_unsafe = ${fmt(m.R_unsafe, 3)}` : '') +
      (D.thrust ? `  ·  largest tilt ${fmt(D.thrust.tilt_max, 1)} deg (agent ${D.thrust.agent}, t = ${fmt(D.thrust.step * DT, 2)} s)` : '') +
      `  ·  positions within ${fmt(D.quant.error * 1000, 2)} mm` + (D.note ? `  ·  ${D.note}` : '');
  }

  // ------------------------------------------------------------------ the hook the tests drive
  const ready = (async () => {
    await load();
    scrub.max = K;
    const target = Math.max(1, K * DT / 20);  // the whole run in about 20 s
    rate = RATES.reduce((b, x) => Math.abs(Math.log(x / target)) < Math.abs(Math.log(b / target)) ? x : b);
    speedSel.value = rate;
    legend(); marks(); layoutTop(); layoutChart();
    await setView(view);
    stats.readyMs = performance.now();
    requestAnimationFrame(frame);
    return true;
  })();
  ready.catch(e => console.error('swarmnav viewer:', e));
  window.swarmnav = {
    ready, data: D,
    /** Go to step s (clamped to 0..K) and draw it; returns the step shown. */
    seek(s) { pause(); seek(s); render(); return k; },
    step: () => k,
    play(x) { if (x) rate = x; play(); }, pause,
    view: v => v ? setView(v).then(() => view) : view,
    /** The agents' positions as drawn at the current step [m]: top-down, read back from the
     * canvas coordinates; perspective, from the arrows' vertices (z included). */
    positions() {
      if (view === 'top') {
        const out = [];
        for (let i = 0; i < N; i++) out.push([(drawn[2 * i] - T.ox) / T.s + lo[0], hi[1] - (drawn[2 * i + 1] - T.oy) / T.s]);
        return out;
      }
      const out = [];
      for (let i = 0; i < N; i++) out.push(arrowAt(i)[0]);
      return out;
    },
    /** Page coordinates [css px] of agent i as drawn in the current view (where to point the mouse). */
    screenOf(i) {
      const r = stage.getBoundingClientRect();
      if (view === 'top') return [r.left + drawn[2 * i], r.top + drawn[2 * i + 1]];
      G.p.set(...arrowAt(i)[0]).project(G.camera);
      return [r.left + (G.p.x + 1) / 2 * stage.clientWidth, r.top + (1 - G.p.y) / 2 * stage.clientHeight];
    },
    /** Page coordinates [css px] of the point [x, y(, z)] [m] in the current view (a planar
     * run's points at its perspective altitude). */
    project(pt) {
      const r = stage.getBoundingClientRect();
      if (view === 'top') return [r.left + X(pt[0]), r.top + Y(pt[1])];
      G.p.set(pt[0], pt[1], DIM === 3 ? pt[2] : G.altitude).project(G.camera);
      return [r.left + (G.p.x + 1) / 2 * stage.clientWidth, r.top + (1 - G.p.y) / 2 * stage.clientHeight];
    },
    /** Perspective: the direction each arrow points (unit vectors, from its instance matrix). */
    headings() {
      const out = [];
      for (let i = 0; i < N; i++) out.push(arrowAt(i)[1]);
      return out;
    },
    /** What the tooltip says of agent i at the current step. */
    agent: i => ({id: i, role: roleOf(k, i), subswarm: D.label_ids[LAB[k * N + i]], speed: speedOf(k, i), clearance: clearanceOf(k, i), tilt: tiltOf(k, i)}),
    /** A quadrotor run's thrust axes as drawn at the current step, per agent (null: the run has
     * none): in perspective [x, y, z], read back from the sticks' vertices over their length;
     * top-down [x, y], the stick's end on the canvas over AXIS_PX (the axis seen from above). */
    thrustAxes() {
      if (!AX) return null;
      const out = [];
      if (view === 'top') {
        for (let i = 0; i < N; i++) out.push([(axisTip[2 * i] - drawn[2 * i]) / AXIS_PX, -(axisTip[2 * i + 1] - drawn[2 * i + 1]) / AXIS_PX]);
        return out;
      }
      const xp = G.axes.geometry.attributes.position.array, len = G.axes.userData.length;
      for (let i = 0; i < N; i++) out.push([0, 1, 2].map(j => (xp[6 * i + 3 + j] - xp[6 * i + j]) / len));
      return out;
    },
    /** What the perspective scene holds: its objects by three.js type (e.g. LineSegments: 4). */
    sceneObjects() {
      if (!G) return null;
      const out = {};
      G.scene.traverse(o => { if (o !== G.scene) out[o.type] = (out[o.type] || 0) + 1; });
      return out;
    },
    stats: () => ({...stats, playing, scale: RES.scale}),
    /** Adaptive resolution of the perspective view: 'adaptive' (the default) or 'full', and
     * optionally the frame budget [ms] (1000 / 30); returns the mode, budget and current scale. */
    resolution(mode, budget) {
      if (mode) setResolution(mode, budget);
      return {mode: RES.adaptive ? 'adaptive' : 'full', budget: RES.budget, scale: RES.scale};
    },
    /** Committed plans: with an argument, show (true) or hide them (as the page's check box)
     * and draw; returns, per robot, its plan as drawn at the current step ([[x, y(, z)], ...]
     * [m] from the current time to the plan's end; null: none) or null when the run has none. */
    plans(on) {
      if (!D.plans) return null;
      if (on !== undefined) { showPlans = !!on; $('plans').checked = showPlans; render(); }
      return Array.from({length: N}, (_, i) => showPlans ? planAhead(i) : null);
    },
    /** The perspective renderer, once loaded: 'three.js r185'. */
    renderer: () => G ? `three.js r${G.THREE.REVISION}` : null,
  };
})();
