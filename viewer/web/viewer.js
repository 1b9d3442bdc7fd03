// The page of evermap-viewer: one WebSocket (subprotocol "evermap") carrying JSON texts, one
// per topic ({"type": "graph" | "pose" | "floor" | "stats" | "history" | "register" |
// "deputy" | "vo" | "image" | "viewer" | "log" | "plans", ...}; docs/viewer.md). The 3-D view
// is loaded on its own (scene.js, three.js), so the counts and plots work even where WebGL
// does not.
import { drawPlot } from './plots.js';

const $ = (id) => document.getElementById(id);
const state = { graph: null, stats: null, register: null, scene: null, graphsDrawn: 0 };
// Timings for bench/viewer_latency.sh (and anyone curious, from the console): per map, when it
// was built by the viewer, received, parsed, put in the scene and drawn, on the wall clock
// (ms since 1970; the viewer and the publisher on the same machine use the same clock).
// `firstMapMs`: from navigation start to the first frame with a map in it (page load time).
const STATS_KEEP = 2000;
const stats = window.evermapStats = { graphs: [], firstMapMs: null, frames: 0 };
const wallNow = () => performance.timeOrigin + performance.now();

function setText(id, v) { const el = $(id); if (el) el.textContent = v; }
const fmtInt = (v) => (v === null || v === undefined) ? '-' : String(v);
const fmtTime = (utime) => new Date(utime / 1000).toISOString().replace('T', ' ').slice(0, 19);

// ---- The 3-D view ----
async function startScene() {
  try {
    const { MapScene } = await import('./scene.js');
    state.scene = new MapScene($('scene'));
    window.evermapScene = state.scene;  // for the browser test and the console
    state.scene.onDrawn = () => {
      stats.frames = state.scene.framesDrawn;
      document.documentElement.dataset.frames = String(state.scene.framesDrawn);
    };
    // The first frame that drew a map: its timings are completed at the next animation frame
    // (the drawn frame was handed to the compositor by then).
    state.scene.onGraphDrawn = (g, renderStart, renderEnd) => {
      const r = g.evermapTimes;
      if (!r) return;
      r.render_start_ms = renderStart; r.render_end_ms = renderEnd;
      requestAnimationFrame(() => { r.next_frame_ms = wallNow(); });
      if (stats.firstMapMs === null && g.nodes.id.length > 0) stats.firstMapMs = performance.now();
    };
    // A click (a press and release that did not drag the view) selects the node under it.
    const canvas = state.scene.renderer.domElement;
    let down = null;
    canvas.addEventListener('pointerdown', (e) => { down = { x: e.clientX, y: e.clientY }; });
    canvas.addEventListener('pointerup', (e) => {
      if (down && Math.hypot(e.clientX - down.x, e.clientY - down.y) < 5) {
        state.scene.select(state.scene.pick(e.clientX, e.clientY));
        showNodeDetails();
      }
      down = null;
    });
    state.scene.onPlanShown = showPlan;
    if (state.plans) state.scene.setPlans(state.plans);
    if (state.graph) showGraphInScene(state.graph);
  } catch (e) {
    setText('scene-message', '3-D view unavailable: ' + e.message + ' (three.js installed by scripts/setup.sh; WebGL needed)');
    console.warn('3-D view unavailable', e);
  }
}

// The plan under the map (--plans): which floor's, or why none.
function showPlan(floor, plan) {
  const d = document.documentElement.dataset;
  const floors = state.plans ? state.plans.floors.map((p) => p.floor) : [];
  $('plan-line').hidden = !state.plans;
  if (plan) {
    setText('plan', `floor ${plan.floor}, ${plan.width}×${plan.height} cells of ${plan.resolution_m} m, ` +
      `${plan.occupied} occupied` + (floors.length > 1 ? ` (plans of floors ${floors.join(', ')})` : ''));
    d.planFloor = String(plan.floor);
    d.planOccupied = String(plan.occupied);
  } else {
    setText('plan', floors.length === 0 ? 'none in ' + (state.plans ? state.plans.dir : '--plans')
      : `none for floor ${floor} (plans of floors ${floors.join(', ')})`);
    delete d.planFloor;
    delete d.planOccupied;
  }
}

function showGraphInScene(g) {
  if (!state.scene) return;
  const t0 = wallNow();
  state.scene.setGraph(g);
  if (g.evermapTimes && g.evermapTimes.scene_ms === undefined) g.evermapTimes.scene_ms = wallNow() - t0;
  $('scene-message').hidden = g.nodes.id.length > 0;
  // Buttons: the 3-D view and a top view per floor.
  const box = $('floor-buttons');
  const floors = [...new Set(g.floors.map((f) => f.index))].sort((a, b) => a - b);
  const have = [...box.querySelectorAll('button')].map((b) => b.dataset.floor).join(',');
  const want = ['all', ...floors.map(String)].join(',');
  if (have !== want) {
    box.innerHTML = '';
    for (const f of ['all', ...floors]) {
      const b = document.createElement('button');
      b.dataset.floor = String(f);
      b.textContent = f === 'all' ? '3-D' : 'floor ' + f;
      const current = state.scene.floorFilter === null ? 'all' : String(state.scene.floorFilter);
      if (String(f) === current) b.classList.add('active');
      b.onclick = () => {
        for (const o of box.querySelectorAll('button')) o.classList.toggle('active', o === b);
        state.scene.showFloor(f === 'all' ? null : f);
      };
      box.appendChild(b);
    }
  }
}

// The selected node's details (a click on a node in the 3-D view), from the newest map.
const EDGE_KINDS = ['odometry', 'loop', 'elevator', 'prior'];
function showNodeDetails() {
  const box = $('node-details');
  const g = state.graph, id = state.scene ? state.scene.selectedId : null;
  const i = state.scene ? state.scene.indexOf(id) : -1;
  if (!g || i < 0) { box.hidden = true; box.dataset.node = ''; return; }
  const count = EDGE_KINDS.map(() => 0);
  const linked = [];
  const e = g.edges;
  for (let k = 0; k < e.a.length; ++k) {
    if (e.a[k] !== i && e.b[k] !== i) continue;
    if (count[e.kind[k]] !== undefined) ++count[e.kind[k]];
    if (e.kind[k] === 1) linked.push(g.nodes.id[e.a[k] === i ? e.b[k] : e.a[k]]);
  }
  const xyz = g.nodes.xyz;
  const edges = EDGE_KINDS.map((name, k) => count[k] + ' ' + name).filter((t) => !t.startsWith('0 ')).join(', ');
  box.hidden = false;
  box.dataset.node = String(id);
  box.innerHTML = '';
  const close = document.createElement('span');
  close.className = 'close';
  close.textContent = '\u00d7';
  close.onclick = () => { state.scene.select(null); showNodeDetails(); };
  box.appendChild(close);
  const lines = [
    'node ' + id + ': session ' + g.nodes.session[i] + ', floor ' + g.nodes.floor[i],
    'at ' + [xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]].map((v) => v.toFixed(2)).join(', ') + ' m',
    'made ' + fmtTime(g.nodes.utime[i]) + ' (data time)',
    'edges: ' + (edges || 'none') + (linked.length ? '; loop closures to ' + linked.slice(0, 12).join(', ') +
      (linked.length > 12 ? ' and ' + (linked.length - 12) + ' more' : '') : ''),
  ];
  for (const t of lines) { const d = document.createElement('div'); d.textContent = t; box.appendChild(d); }
}

// ---- Topics ----
const handlers = {
  graph(g) {
    state.graph = g;
    const c = g.counts;
    setText('count-nodes', c.nodes);
    setText('count-edges', c.edges);
    setText('count-floors', c.floors);
    setText('count-sessions', c.sessions);
    setText('count-closures', c.closures);
    if (g.source !== 'live') setText('source', 'map store ' + g.source);
    else if (g.utime) setText('clock', 'map at ' + fmtTime(g.utime));
    showGraphInScene(g);
    if (state.scene && state.scene.selectedId !== null) showNodeDetails();
    // Latency from the viewer's text to this frame's drawing (same machine, same clock).
    requestAnimationFrame(() => {
      if (g.source === 'live') setText('latency', (Date.now() - g.built_ms) + ' ms for ' + c.nodes + ' nodes');
      ++state.graphsDrawn;
      document.documentElement.dataset.graphNodes = String(c.nodes);
      document.documentElement.dataset.graphsDrawn = String(state.graphsDrawn);
    });
  },
  pose(p) {
    const s = p.sigma_xy_m === null ? '' : ' ±' + p.sigma_xy_m.toFixed(2) + ' m';
    setText('pose', p.xyz.map((v) => v.toFixed(2)).join(', ') + ' m' + s + ' (session ' + p.session + ')');
    if (state.scene) state.scene.setPose(p);
  },
  plans(m) {
    state.plans = m;
    if (state.scene) state.scene.setPlans(m);
    else showPlan(null, null);
  },
  floor(f) {
    setText('floor', (f.floor_index < 0 ? 'unknown' : f.floor_index) + ' at ' + f.height_m.toFixed(1) + ' m' +
      (f.in_elevator ? ', in the elevator' : '') + (f.new_floor ? ' (new)' : ''));
  },
  stats(s) {
    state.stats = s;
    setText('count-rejected', s.rejected);
    setText('count-dropped', s.dropped);
    // The mapper's named counters (warm restarts, plausibility refusals, ...).
    setText('mapper-counters', (s.counters || []).map(([name, value]) => name.replace(/_/g, ' ') + ' ' + value).join(', ') || '-');
    if (!state.graph) { setText('count-floors', s.floors); setText('count-sessions', s.sessions); }
  },
  history(h) {
    if (h.utime.length === 0) return;
    // Data time in minutes: a step of an hour or more (the gap between two sessions) counts
    // as nothing, as in the mapper's progress lines.
    const minutes = [0];
    for (let k = 1; k < h.utime.length; ++k) {
      const step = h.utime[k] - h.utime[k - 1];
      minutes.push(minutes[k - 1] + (step > 0 && step < 3.6e9 ? step / 6e7 : 0));
    }
    drawPlot($('plot-nodes'), [{ label: 'nodes', x: minutes, y: h.nodes }], 'data time, min', 'nodes');
    const series = Object.entries(h.components).map(([name, ms]) => ({ label: name, x: minutes, y: ms }));
    drawPlot($('plot-components'), series, 'data time, min', 'ms');
  },
  register(r) {
    setText('count-reg-ok', r.ok);
    setText('count-reg-failed', r.failed);
    const l = r.last;
    setText('register', l.status + (l.status === 'ok' ? ' to node ' + l.node_id + ', ' + l.inliers + ' inliers' : (l.reason ? ': ' + l.reason : '')));
  },
  deputy(d) {
    const body = $('deputy').querySelector('tbody');
    body.innerHTML = '';
    for (const h of d.hosts) for (const p of h.procs) {
      const tr = document.createElement('tr');
      const cells = [h.host, p.name, p.state, p.pid || '-', p.restarts, p.cpu_percent === null ? '-' : p.cpu_percent.toFixed(0),
                     (p.rss_bytes / 1048576).toFixed(0)];
      cells.forEach((v, k) => {
        const td = document.createElement('td');
        td.textContent = String(v);
        if (k === 2) td.className = p.state;
        tr.appendChild(td);
      });
      body.appendChild(tr);
    }
  },
  vo(v) {
    setText('vo', v.status + ': ' + v.inliers + ' inliers of ' + v.matches + ' matches, ' + v.features + ' features');
  },
  image(m) {
    const img = new Image();
    img.onload = () => {
      const c = $('image');
      c.hidden = false;
      $('image-none').hidden = true;
      c.width = img.width; c.height = img.height;
      const ctx = c.getContext('2d');
      ctx.drawImage(img, 0, 0);
      // The newest keyframe's features, when it is this frame or close to it (1 s).
      if (m.features_utime >= 0 && Math.abs(m.utime - m.features_utime) < 1e6) {
        ctx.strokeStyle = '#5f5';
        for (let k = 0; k + 1 < m.features.length; k += 2) {
          ctx.beginPath();
          ctx.arc(m.features[k] * m.scale, m.features[k + 1] * m.scale, 2, 0, 2 * Math.PI);
          ctx.stroke();
        }
      }
    };
    img.src = 'data:image/jpeg;base64,' + m.jpeg;
  },
  // --log: the slider follows the position unless the user holds it.
  log(l) {
    $('log-controls').hidden = false;
    setText('source', 'log ' + l.file);
    if (state.log && l.t < state.log.t && state.scene) state.scene.restart();
    state.log = window.evermapLog = l;  // (the browser test reads the speed the viewer plays at)
    const span = Math.max(1, l.end - l.start);
    if (!state.sliding) $('log-slider').value = String(Math.round(1000 * (l.t - l.start) / span));
    setText('log-time', ((l.t - l.start) / 1e6).toFixed(1) + ' / ' + (span / 1e6).toFixed(1) + ' s');
    setText('log-play', l.playing ? 'pause' : 'play');
    const speed = $('log-speed');
    if (document.activeElement !== speed) {
      const v = String(Number(l.speed));
      if (![...speed.options].some((o) => o.value === v)) speed.add(new Option(v, v));
      speed.value = v;
    }
  },
  viewer(v) {
    setText('count-viewer-dropped', v.dropped);
    const s = v.server || {};
    setText('viewer-counts', 'viewer: ' + v.received + ' messages received, ' + v.dropped + ' dropped; ' +
      (s.clients ?? '-') + ' browsers, ' + (s.versions_skipped ?? 0) + ' updates skipped for slow browsers');
  },
};

// ---- The stream ----
function command(text) {
  if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(text);
}

function connect() {
  const ws = state.ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/', 'evermap');
  ws.onopen = () => { const c = $('connection'); c.textContent = 'live'; c.className = 'good'; };
  ws.onclose = () => {
    const c = $('connection'); c.textContent = 'disconnected, retrying'; c.className = 'bad';
    setTimeout(connect, 1000);
  };
  ws.onmessage = (e) => {
    let m;
    const received = wallNow();
    try { m = JSON.parse(e.data); } catch (err) { console.warn('not JSON', err); return; }
    if (m.type === 'graph') {
      m.evermapTimes = { utime: m.utime, nodes: m.nodes.id.length, bytes: e.data.length, built_ms: m.built_ms,
                         received_ms: received, parse_ms: wallNow() - received };
      stats.graphs.push(m.evermapTimes);
      if (stats.graphs.length > STATS_KEEP) stats.graphs.splice(0, stats.graphs.length - STATS_KEEP);
    }
    const h = handlers[m.type];
    try {
      if (h) h(m);
    } finally {
      // One acknowledgement per text handled: the viewer sends at most a few unacknowledged
      // texts, so a busy page gets the newest state when it is ready, not a backlog.
      if (ws.readyState === WebSocket.OPEN) ws.send('a');
    }
  };
}

$('exaggeration').addEventListener('input', (e) => {
  const v = Number(e.target.value);
  setText('exaggeration-value', String(v));
  if (state.scene) state.scene.setExaggeration(v);
});
$('log-slider').addEventListener('input', () => { state.sliding = true; });
$('log-slider').addEventListener('change', (e) => {
  state.sliding = false;
  if (!state.log) return;
  const t = state.log.start + Math.round(Number(e.target.value) / 1000 * (state.log.end - state.log.start));
  command('seek ' + t);
});
$('log-play').addEventListener('click', () => command(state.log && state.log.playing ? 'pause' : 'play'));
$('log-speed').addEventListener('change', (e) => command('speed ' + e.target.value));
$('follow').addEventListener('change', (e) => { if (state.scene) state.scene.follow = e.target.checked; });
drawPlot($('plot-nodes'), [], 'data time, min', 'nodes');
drawPlot($('plot-components'), [], 'data time, min', 'ms');
connect();
startScene();
