// granulard dashboard: one multiplexed SSE stream (/api/v1/events) keeps the job table, the open job and the cluster panel live.
'use strict';
(function () {
  const $ = (id) => document.getElementById(id);
  const TOKEN_KEY = 'granulard.token';
  const TERMINAL = new Set(['succeeded', 'failed', 'cancelled']);
  const jobs = new Map();          // id -> job JSON (without scene)
  let view = { job: 0 };           // the open job page, 0 = list
  let series = null;               // {job, after, t, T, Trot, rate, cl, recs, scene, panels, rot}
  let plots = [];

  // ---- HTTP: every request carries the saved token as a header, never in the URL (reads may need it: read_auth) ----
  function authHeaders() {
    const token = localStorage.getItem(TOKEN_KEY);
    return token ? { Authorization: 'Bearer ' + token } : {};
  }
  async function api(method, path, body) {
    const headers = authHeaders();
    if (body !== undefined) headers['Content-Type'] = 'application/json';
    const r = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
    const j = await r.json().catch(() => null);
    if (!r.ok) throw new Error(j && j.error ? j.error.message : 'HTTP ' + r.status);
    return j;
  }

  // ---- helpers ----
  const pct = (p) => (Number.isFinite(p) ? (100 * p).toFixed(1) + '%' : '-');
  function si(v) {
    if (!Number.isFinite(v)) return '-';
    const u = ['', 'k', 'M', 'G', 'T']; let i = 0;
    while (Math.abs(v) >= 1000 && i < u.length - 1) { v /= 1000; i++; }
    return (i ? v.toPrecision(3) : String(Math.round(v))) + u[i];
  }
  function age(t) {
    const s = Date.now() / 1000 - t;
    if (!Number.isFinite(s)) return '-';
    return s < 60 ? Math.floor(s) + 's' : s < 3600 ? Math.floor(s / 60) + 'm' : s < 86400 ? Math.floor(s / 3600) + 'h' : Math.floor(s / 86400) + 'd';
  }
  function el(tag, attrs, ...kids) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    for (const k of kids) e.append(k instanceof Node ? k : document.createTextNode(String(k)));
    return e;
  }
  function badge(state) { return el('span', { class: 'badge ' + state }, state); }
  function bar(p) { const b = el('div', { class: 'bar' }, el('div')); b.firstChild.style.width = (Number.isFinite(p) ? 100 * p : 0) + '%'; return b; }
  function throttle(fn, ms) {
    let last = 0, timer = null;
    return function () {
      const wait = last + ms - Date.now();
      if (timer) return;
      timer = setTimeout(() => { timer = null; last = Date.now(); fn(); }, Math.max(0, wait));
    };
  }
  function dl(node, rows) {
    node.replaceChildren();
    for (const [k, v] of rows) node.append(el('dt', {}, k), el('dd', {}, v));
  }
  const plural = (n, word) => n + ' ' + word + (n === 1 ? '' : 's');
  function bytes(v) {
    if (!Number.isFinite(v)) return '-';
    const u = ['B', 'KiB', 'MiB', 'GiB', 'TiB']; let i = 0;
    while (v >= 1024 && i < u.length - 1) { v /= 1024; i++; }
    return (i ? v.toPrecision(3) : String(v)) + ' ' + u[i];
  }
  const when = (t) => (Number.isFinite(t) ? new Date(t * 1000).toLocaleString() : '-');
  // Error lines by source ({box: {source: text}}): a source that succeeds again takes its own error away,
  // so no message outlives what it was about.
  const errors = {};
  function setError(box, source, text) {
    const m = errors[box] || (errors[box] = {});
    if (text) m[source] = text; else delete m[source];
    const node = $(box);
    node.textContent = Object.values(m).join('; ');
    node.hidden = !node.textContent;
  }
  function clearErrors(box) { errors[box] = {}; setError(box, '', ''); }

  // ---- job table ----
  function renderJobs() {
    const body = $('jobs').tBodies[0], filter = $('filter').value;
    const rows = [...jobs.values()].filter((j) => !filter || j.state === filter).sort((a, b) => b.id - a.id);
    body.replaceChildren(...rows.map((j) => {
      const tr = el('tr', { 'data-id': j.id },
        el('td', {}, j.id), el('td', {}, badge(j.state)),
        el('td', {}, bar(j.progress), pct(j.progress)), el('td', {}, j.method || '-'),
        el('td', {}, si(j.particles)), el('td', {}, Number.isFinite(j.sim_time) ? j.sim_time.toPrecision(4) : '-'),
        el('td', {}, age(j.created_at)), el('td', {}));
      if (!TERMINAL.has(j.state)) {
        const b = el('button', { type: 'button' }, 'cancel');
        b.addEventListener('click', (ev) => { ev.stopPropagation(); cancel(j.id, j.state); });
        tr.lastChild.append(b);
      }
      tr.addEventListener('click', () => { location.hash = '#/job/' + j.id; });
      return tr;
    }));
  }
  async function loadJobs() {
    try {
      const r = await api('GET', '/api/v1/jobs?limit=200');
      jobs.clear();
      for (const j of r.jobs) jobs.set(j.id, j);
      renderJobs();
      setError('jobs-msg', 'load', '');
    } catch (e) { setError('jobs-msg', 'load', 'jobs: ' + e.message); }
  }
  // Progress moves between state events: refresh the unfinished jobs at most once a second.
  const refreshActive = throttle(async () => {
    try {
      const r = await api('GET', '/api/v1/jobs?state=queued,running&limit=200');
      for (const j of r.jobs) jobs.set(j.id, j);
      renderJobs();
      if (view.job && jobs.has(view.job)) renderJob(jobs.get(view.job));
    } catch (e) { /* the stream status shows connectivity */ }
  }, 1000);

  // Cancelling cannot be undone (a running job is stopped, at best from its checkpoint): ask first.
  async function cancel(id, state) {
    if (!confirm('Cancel job ' + id + (state ? ' (' + state + ')' : '') + '? This cannot be undone.')) return;
    const box = view.job ? 'job-msg' : 'jobs-msg';
    try { await api('POST', '/api/v1/jobs/' + id + '/cancel'); setError(box, 'cancel', ''); }
    catch (e) { setError(box, 'cancel', 'cancel job ' + id + ': ' + e.message); }
  }

  // ---- compute cluster ----
  // With launcher = slurm, GET /api/v1/cluster adds the partition (docs/daemon.md, "Running on a cluster"),
  // or {"error": ...} when sinfo or squeue did not answer.
  function slurmRows(s) {
    if (!s) return [];
    if (s.error) return [['partition', 'unknown: ' + s.error]];
    const n = s.nodes || {}, c = s.cpus || {};
    return [
      ['partition', s.partition + ', ' + plural(n.total, 'node')],
      ['nodes', n.idle + ' idle, ' + n.allocated + ' allocated' + (n.mixed ? ', ' + n.mixed + ' mixed' : '') + (n.other ? ', ' + n.other + ' other' : '')],
      ['CPUs', c.idle + ' idle, ' + c.allocated + ' allocated of ' + c.total],
      ['pending', plural(s.pending_jobs, 'Slurm job')],
    ];
  }
  const loadCluster = throttle(async () => {
    try {
      const c = await api('GET', '/api/v1/cluster');
      const byState = Object.entries(c.jobs || {}).map(([k, v]) => k + ' ' + v).join(', ');
      dl($('cluster-stats'), [
        ['version', c.version], ['uptime', Math.round(c.uptime_seconds) + ' s'], ['launcher', c.launcher || '-'],
        ['slots', c.slots.used + ' / ' + c.slots.total + ' used'], ['jobs', byState],
        ['running', (c.running || []).map((r) => '#' + r.id + ' ' + pct(r.progress)).join(', ') || '-'],
        ['last hour', c.finished_last_hour + ' finished'], ['events/s', si(c.events_per_second)],
      ].concat(slurmRows(c.slurm)));
    } catch (e) { dl($('cluster-stats'), [['error', e.message]]); }
  }, 2000);

  // ---- submit form with presets ----
  let presets = [];
  async function loadPresets() {
    try {
      presets = (await api('GET', '/api/v1/presets')).presets;
      $('preset').replaceChildren(...presets.map((p) => el('option', { value: p.name }, p.name + ' (' + p.dimensions + 'D, N=' + si(p.particles) + ')')));
      showPreset();
    } catch (e) { $('submit-msg').textContent = 'presets: ' + e.message; }
  }
  function showPreset() {
    const p = presets.find((x) => x.name === $('preset').value);
    if (!p) return;
    $('preset-desc').textContent = p.description;
    $('scene').value = JSON.stringify(p.scene, null, 2);
    formChanged();
  }
  // The advice and the last message were about the form as it was: drop them when it changes.
  function formChanged() {
    $('advice').hidden = true; $('advice').replaceChildren();
    const msg = $('submit-msg'); msg.className = ''; msg.textContent = '';
  }
  async function submit(ev) {
    ev.preventDefault();
    const msg = $('submit-msg');
    let scene;
    try { scene = JSON.parse($('scene').value); } catch (e) { msg.className = 'err'; msg.textContent = 'scene: ' + e.message; return; }
    try {
      const j = await api('POST', '/api/v1/jobs', { scene, priority: Number($('priority').value), ranks: Number($('ranks').value) });
      msg.className = 'ok'; msg.textContent = 'job ' + j.id + ' ' + j.state;
      jobs.set(j.id, j); renderJobs();
    } catch (e) { msg.className = 'err'; msg.textContent = e.message; }
  }

  // ---- method advice (POST /api/v1/advice; a job's "advice" for method auto) ----
  const num = (v, p) => (Number.isFinite(v) ? v.toPrecision(p || 3) : '-');
  function settingsText(e) {
    const s = e.settings || {};
    if (e.method === 'ed') return 'cell ' + (s.cell_size ?? 'automatic');
    const step = s.time_step ? 'step ' + num(s.time_step) : num(s.collisions_per_step, 2) + ' coll/step';
    return 'cell ' + num(s.cell_size) + ', ' + step;
  }
  // The decision (chosen variant and the first clause of the reason) and every candidate's cost and error.
  function adviceView(a) {
    const kids = [];
    const chosen = a.choice_variant || a.choice;
    const sc = a.scene || {};
    kids.push(el('p', { class: 'muted' }, (sc.particles ?? '?') + ' particles x ' + plural(sc.replicas ?? 1, 'replica') + ', ' +
      plural(sc.ranks ?? 1, 'rank') + '; Haff time ' + num(sc.haff_time) + (a.target ? '; target: temperature error <= ' + a.target.temperature : '; no target (method ' + (sc.method || '?') + ')')));
    if (chosen) {
      const [first, ...rest] = (a.reason || '').split('; ');
      kids.push(el('p', { class: 'reason' }, el('strong', {}, 'chosen: ' + chosen), ' \u2014 ' + first));
      if (rest.length) kids.push(el('p', { class: 'more muted' }, rest.join('; ')));
    }
    const head = el('tr', {}, ...['variant', 'settings', 'CPU s', 'wall s', 'expected error', 'meets', 'extrapolated'].map((h) => el('th', {}, h)));
    const rows = (a.estimates || []).map((e) => {
      const m = e.meets_target;
      const tr = el('tr', { 'data-variant': e.variant, title: (e.notes || []).join('; ') },
        el('td', {}, e.variant), el('td', {}, settingsText(e)), el('td', {}, num(e.cpu_seconds)), el('td', {}, num(e.wall_seconds)),
        el('td', {}, num(e.error && e.error.temperature)), el('td', {}, m === true ? 'yes' : m === false ? 'no' : '-'),
        el('td', {}, e.extrapolated ? 'yes' : ''));
      if (chosen && e.variant === chosen) tr.className = 'chosen';
      return tr;
    });
    kids.push(el('table', {}, el('thead', {}, head), el('tbody', {}, ...rows)));
    return kids;
  }
  async function advise() {
    const msg = $('submit-msg'), box = $('advice');
    let scene;
    try { scene = JSON.parse($('scene').value); } catch (e) { msg.className = 'err'; msg.textContent = 'scene: ' + e.message; return; }
    try {
      const a = await api('POST', '/api/v1/advice', { scene, ranks: Number($('ranks').value) });
      box.replaceChildren(el('h3', {}, 'Advice'), ...adviceView(a));
      box.hidden = false;
      msg.className = ''; msg.textContent = '';
    } catch (e) { box.hidden = true; msg.className = 'err'; msg.textContent = 'advice: ' + e.message; }
  }
  function renderJobAdvice(j) {
    const box = $('job-advice');
    if (!j.advice) { box.hidden = true; box.replaceChildren(); return; }
    box.replaceChildren(el('h3', {}, 'Method advice (method auto, decided at submission)'), ...adviceView(j.advice));
    box.hidden = false;
  }

  // ---- job page: record, live plots ----
  function renderJob(j) {
    $('job-id').textContent = j.id;
    const b = $('job-state'); b.className = 'badge ' + j.state; b.textContent = j.state;
    $('job-bar').style.width = (Number.isFinite(j.progress) ? 100 * j.progress : 0) + '%';
    $('job-cancel').hidden = TERMINAL.has(j.state);
    dl($('job-info'), [
      ['progress', pct(j.progress)], ['method', j.method + ', N=' + si(j.particles) + ', ' + plural(j.ranks, 'rank')],
      ['sim time', Number.isFinite(j.sim_time) ? j.sim_time.toPrecision(5) : '-'], ['events', si(j.events)],
      ['created', when(j.created_at)], ['reason', j.reason || '-'],
    ].concat(j.cancel_requested && !TERMINAL.has(j.state) ? [['cancel', 'requested: the job is stopping']] : []));
    if (j.advice !== undefined) renderJobAdvice(j);
    if (j.attempts !== undefined) renderAttempts(j.attempts);
    if (j.split !== undefined) renderSplit(j.split);
  }
  // A split ed run (docs/daemon.md, "Split runs"): each rank's events processed (rolled-back ones included) and
  // particles owned, with the rollbacks, syncs, sync interval and rebalances; from the job or its newest record.
  function renderSplit(sp) {
    const box = $('job-split');
    if (!sp || !Number.isFinite(sp.ranks)) { box.hidden = true; return; }
    const ev = sp.rank_events || [], np = sp.rank_particles || [];
    const total = ev.reduce((a, b) => a + b, 0), mean = ev.length ? total / ev.length : 0;
    const imb = mean > 0 ? Math.max(...ev) / mean : NaN;
    $('job-split-info').textContent = plural(sp.ranks, 'rank') + (Number.isFinite(sp.time) ? ' at t = ' + sp.time.toPrecision(5) : '') +
      ': rollbacks ' + si(sp.rollbacks) + ', syncs ' + si(sp.syncs) + ', sync interval ' +
      (Number.isFinite(sp.sync_interval) ? sp.sync_interval.toPrecision(3) : '-') + ', rebalances ' + si(sp.rebalances) +
      (Number.isFinite(imb) ? ', busiest / mean events ' + imb.toFixed(3) : '');
    $('job-ranks').tBodies[0].replaceChildren(...ev.map((e, r) => el('tr', { 'data-rank': r }, el('td', {}, r),
      el('td', {}, si(e)), el('td', {}, total > 0 ? (100 * e / total).toFixed(1) + '%' : '-'), el('td', {}, np[r] != null ? si(np[r]) : '-'))));
    $('job-ranks').hidden = !ev.length;
    box.hidden = false;
  }
  function renderAttempts(list) {
    $('job-attempts').tBodies[0].replaceChildren(...list.map((a) => {
      const result = a.exit_status != null ? 'exit ' + a.exit_status : a.signal != null ? 'signal ' + a.signal
        : a.ended_at == null ? 'running' : '-';
      const cell = el('td', {}, result + (a.reason ? ': ' + a.reason : ''));
      // launcher = slurm: the attempt's Slurm job and its state as granulard names it (with Slurm's reason).
      if (a.slurm_job != null) cell.append(el('div', { class: 'slurm' }, 'Slurm job ' + a.slurm_job + (a.slurm_state ? ': ' + a.slurm_state : '')));
      if (a.stderr_tail) cell.append(el('pre', { class: 'stderr' }, a.stderr_tail.trim().split('\n').slice(-3).join('\n')));
      return el('tr', { 'data-n': a.n }, el('td', {}, a.n), el('td', {}, when(a.started_at)), el('td', {}, when(a.ended_at)),
        cell, el('td', {}, a.checkpoint || '-'));
    }));
    $('job-attempts').hidden = !list.length;
    $('job-attempts-none').hidden = list.length > 0;
  }
  // A plain link, but with a saved token the download goes through fetch() with the header (read_auth token):
  // a link cannot send it, and the token never goes into a URL.
  function fileLink(href, name) {
    const a = el('a', { href, download: name }, name);
    a.addEventListener('click', async (ev) => {
      if (!localStorage.getItem(TOKEN_KEY)) return;
      ev.preventDefault();
      try {
        const r = await fetch(href, { headers: authHeaders() });
        if (!r.ok) throw new Error('HTTP ' + r.status);
        const url = URL.createObjectURL(await r.blob());
        const t = el('a', { href: url, download: name });
        document.body.append(t); t.click(); t.remove();
        setTimeout(() => URL.revokeObjectURL(url), 10000);
      } catch (e) { setError('job-msg', 'files', name + ': ' + e.message); }
    });
    return a;
  }
  async function loadFiles(id) {
    try {
      const r = await api('GET', '/api/v1/jobs/' + id + '/files');
      if (view.job !== id) return;
      $('job-files').tBodies[0].replaceChildren(...r.files.map((f) => el('tr', { 'data-name': f.name },
        el('td', {}, fileLink('/api/v1/jobs/' + id + '/files/' + encodeURIComponent(f.name), f.name)),
        el('td', {}, bytes(f.size)), el('td', {}, age(f.modified) + ' ago'),
        el('td', { class: 'sha', title: f.sha256 || '' }, (f.sha256 || '-').slice(0, 16)))));
      $('job-files').hidden = !r.files.length;
      $('job-files-none').hidden = r.files.length > 0;
      setError('job-msg', 'files', '');
    } catch (e) { if (view.job === id) setError('job-msg', 'files', 'files: ' + e.message); }
  }
  // The record (with attempts) and the files: on opening a job and when its state changes.
  async function loadJob(id) {
    try {
      const j = await api('GET', '/api/v1/jobs/' + id + '?scene=0');
      if (view.job !== id) return;
      jobs.set(id, j); renderJob(j);
      setError('job-msg', 'job', '');
    } catch (e) { if (view.job === id) setError('job-msg', 'job', 'job ' + id + ': ' + e.message); }
    loadFiles(id);
  }
  // Haff's law: sqrt(T0/T) - 1 = t/tau; least squares through the origin over the early records (T > T0/4).
  function haff(t, T) {
    const T0 = T[0]; let stt = 0, sty = 0;
    for (let i = 1; i < t.length; i++) {
      if (!(T[i] > T0 / 4)) break;
      const y = Math.sqrt(T0 / T[i]) - 1; stt += t[i] * t[i]; sty += t[i] * y;
    }
    return sty > 0 ? { T0, tau: stt / sty } : null;
  }
  function makePlots() {
    for (const p of plots) p.destroy();
    plots = [];
    if (!window.uPlot) return;
    const w = Math.max(380, $('plot-energy').clientWidth || 420), h = 240;
    const base = (label, logy, extra) => ({
      width: w, height: h, scales: { x: { time: false, distr: logy ? 3 : 1 }, y: { distr: logy ? 3 : 1 } },
      // log axes: decades as 1e-4 rather than uPlot's rounded "0"
      axes: [{ label: 'time' }, logy ? { values: (u, vals) => vals.map((v) => (v == null ? '' : v >= 0.01 && v < 1e4 ? String(+v.toPrecision(3)) : v.toExponential(0))) } : {}], series: [{ label: 't' }, { label, stroke: '#2f6fde', width: 2, points: { show: false } }].concat(extra || []),
    });
    // rough particles: T_rot beside T (series 3), once the scene is known to ask for it
    const rot = series && series.rot ? [{ label: 'T_rot', stroke: TROT, width: 2, points: { show: false } }] : [];
    plots.push(new uPlot(base('T', true, [{ label: "Haff", stroke: '#d2691e', dash: [6, 4], width: 1.5, points: { show: false } }].concat(rot)),
      [[], [], []].concat(rot.map(() => [])), $('plot-energy')));
    plots.push(new uPlot(base('collisions/particle/time', false), [[], []], $('plot-rate')));
    plots.push(new uPlot(base('largest fraction', false), [[], []], $('plot-cluster')));
  }
  // A plot without a single value says so ("no data": the observable was not asked for, or no record yet).
  function noData(id, ys) {
    $(id + '-nodata').hidden = !series || !series.loaded || ys.some((v) => Number.isFinite(v));
  }
  function drawPlots() {
    if (!series) return;
    const { t, T, rate, cl } = series;
    noData('plot-energy', T); noData('plot-rate', rate); noData('plot-cluster', cl);
    $('plot-energy').dataset.records = t.length;   // the progress records drawn (tests/browser_test.js counts them)
    drawObs();
    if (plots.length < 3) return;
    // log axes: drop t = 0 (the initial record) from the log-log plot
    const i0 = t.length && t[0] <= 0 ? 1 : 0;
    const fit = haff(t, T), tl = t.slice(i0);
    const H = tl.map((x) => (fit ? fit.T0 / Math.pow(1 + x / fit.tau, 2) : null));
    plots[0].setData([tl, T.slice(i0), H].concat(series.rot ? [series.Trot.slice(i0).map(pos)] : []));
    plots[1].setData([t, rate]);
    plots[2].setData([t, cl]);
    $('haff').textContent = fit ? 'Haff fit: T0 = ' + fit.T0.toPrecision(3) + ', tau = ' + fit.tau.toPrecision(3) +
      ' (early records with T > T0/4); departures at late times mark clustering' : '';
    const k = T.length - 1;
    if (series.rot && k >= 0 && T[k] > 0 && Number.isFinite(series.Trot[k]))
      $('haff').textContent += (fit ? '. ' : '') + 'T_rot/T = ' + (series.Trot[k] / T[k]).toPrecision(3) + ' at time ' + (+t[k].toPrecision(4)) + ' (1 in equipartition)';
  }
  // ---- progress series of walls, gravity, obstacles, open walls, rough particles and diffusion (docs/engine.md) ----
  // Once per job: which plotted curves and panels does its scene ask for (output.observables)?
  async function loadScene(id) {
    let j;
    try { j = await api('GET', '/api/v1/jobs/' + id); } catch (e) { if (series && series.job === id) series.sceneP = null; return; }
    if (!series || series.job !== id) return;
    const sc = j.scene || {}, obs = (sc.output && sc.output.observables) || [];
    series.scene = sc; series.dim = sc.dimensions;
    series.curves = CURVE_OBS.filter((o) => obs.includes(o));
    series.panels = OBS_PANELS.filter((p) => p.shown(obs));
    for (const p of OBS_PANELS) $('panel-' + p.id).hidden = !series.panels.includes(p);
    series.rot = obs.includes('rotational_temperature');
    $('trot-title').hidden = !series.rot;
    if (series.rot) makePlots();
    drawPlots();
  }

  const TROT = '#2a9d4a';
  const COLORS = ['#2f6fde', '#d2691e', TROT, '#9b59b6', '#c0392b', '#16a0a8', '#7a5a00', '#6b7385'];
  const fin = (v) => (Number.isFinite(v) ? v : null);
  const fmt = (v) => (Number.isFinite(v) ? String(+v.toPrecision(3)) : '-');
  const cnt = (v) => (Number.isFinite(v) ? String(v) : '-');   // counts in full: they are compared with the records
  const last = (recs) => recs[recs.length - 1] || {};
  const AXES = ['x', 'y', 'z'];
  // The mean flow that defines drag and lift: the initial stream (particles.initial.velocity), else gravity.
  function flow(sc) {
    const cands = [[(sc.particles && sc.particles.initial && sc.particles.initial.velocity), 'the initial stream'], [sc.gravity, 'gravity']];
    for (const [v, what] of cands) {
      const n = Array.isArray(v) ? Math.hypot(...v) : 0;
      if (n > 0) return { dir: v.map((x) => x / n), what };
    }
    return null;
  }
  // The open walls of the scene ("x.upper"), in the engine's order: the outflow object has only those passed so far.
  function openWalls(sc) {
    const names = [];
    for (const a of AXES) {
      const b = sc.boundaries && sc.boundaries[a];
      if (b && b.type === 'walls') for (const end of ['lower', 'upper']) if (b[end] && (b[end].type === 'open' || b[end].type === 'reservoir')) names.push(a + '.' + end);
    }
    return names;
  }
  // One panel per progress observable: shown(observables), then lines(records, scene) -> {labels, cols, info};
  // log: log-log axes (t = 0 and values <= 0 left out); dash: per series.
  const OBS_PANELS = [
    { id: 'walls', ylabel: 'pressure', shown: (o) => o.includes('wall_force'),
      lines(recs) {
        const labels = [];
        for (const r of recs) for (const w of r.wall_force || []) if (!labels.includes(w.wall)) labels.push(w.wall);
        const cols = labels.map((nm) => recs.map((r) => fin(((r.wall_force || []).find((w) => w.wall === nm) || {}).pressure)));
        const l = last(recs);
        const force = (l.wall_force || []).filter((w) => (w.force || []).some(Number.isFinite))
          .map((w) => w.wall + ' (' + w.force.map(fmt).join(', ') + ')');
        return { labels, cols, info: recs.length ? cnt(l.wall_collisions) + ' wall collisions so far' + (force.length ? '; mean force on each wall over the last interval: ' + force.join(', ') : '') : '' };
      } },
    { id: 'obstacles', ylabel: 'force', shown: (o) => o.includes('obstacle_force'),
      lines(recs, sc) {
        const fl = flow(sc), D = sc.dimensions || 2;
        let k = 0;
        for (const r of recs) k = Math.max(k, (r.obstacle_force || []).length);
        const labels = [], cols = [];
        const at = (r, i) => { const f = (r.obstacle_force || [])[i]; return f && f.length && f.every(Number.isFinite) ? f : null; };
        for (let i = 0; i < k; i++) {
          if (fl) {
            const d = fl.dir, along = (f) => f.reduce((a, x, j) => a + x * d[j], 0);
            labels.push('obstacle ' + i + ' drag', 'obstacle ' + i + ' lift');
            cols.push(recs.map((r) => { const f = at(r, i); return f ? along(f) : null; }));
            // 2D: the signed component 90 degrees anticlockwise from the flow; 3D: the magnitude across it
            cols.push(recs.map((r) => {
              const f = at(r, i);
              if (!f) return null;
              if (f.length === 2) return f[1] * d[0] - f[0] * d[1];
              const a = along(f);
              return Math.hypot(...f.map((x, j) => x - a * d[j]));
            }));
          } else {
            for (let j = 0; j < D; j++) {
              labels.push('obstacle ' + i + ' F_' + AXES[j]);
              cols.push(recs.map((r) => { const f = at(r, i); return f ? f[j] : null; }));
            }
          }
        }
        const l = last(recs);
        return { labels, cols, info: (recs.length ? cnt(l.obstacle_collisions) + ' particle-obstacle hits so far; ' : '') +
          (fl ? 'flow along (' + fl.dir.map(fmt).join(', ') + '), the direction of ' + fl.what + (D === 2 ? '; lift: the component 90\u00b0 anticlockwise from it' : '; lift: the magnitude across it')
            : 'no mean flow in the scene: the force\'s components') };
      } },
    { id: 'outflow', ylabel: 'particles', shown: (o) => o.includes('outflow'),
      lines(recs, sc) {
        const names = openWalls(sc);
        for (const r of recs) for (const w of Object.keys(r.outflow || {})) if (!names.includes(w)) names.push(w);
        // reservoir walls (docs/scene.md) also let particles in: their inflow counts per wall
        const ins = [];
        for (const r of recs) for (const w of Object.keys(r.inflow || {})) if (!ins.includes(w)) ins.push(w);
        // ensembles: the counts are totals over the replicas (docs/scene.md); present is shown per replica
        const per = (r) => (r.replicas > 1 ? r.particles_present / r.replicas : r.particles_present);
        const cols = [recs.map((r) => fin(per(r)))]
          .concat(names.map((w) => recs.map((r) => (r.outflow ? fin(r.outflow[w] ?? 0) : null))))
          .concat(ins.map((w) => recs.map((r) => (r.inflow ? fin(r.inflow[w] ?? 0) : null))));
        const l = last(recs);
        const sum = (o) => Object.values(o || {}).reduce((a, x) => a + x, 0);
        return { labels: [l && l.replicas > 1 ? 'present (per replica)' : 'present'].concat(names.map((w) => 'out ' + w), ins.map((w) => 'in ' + w)), cols,
          info: recs.length ? cnt(l.particles_present) + ' particles present at time ' + fmt(l.time) +
            (l.replicas > 1 ? ' (all ' + l.replicas + ' replicas together; the counts are totals)' : '') +
            (ins.length ? '; ' + cnt(sum(l.inflow)) + ' came in through reservoir walls (' + cnt(sum(l.inflow_rejected)) +
              ' entries rejected: overlap)' : '') : '' };
      } },
    { id: 'height', ylabel: 'height', shown: (o) => o.includes('center_of_mass_height'),
      lines(recs) {
        const h = recs.map((r) => fin(r.center_of_mass_height));
        const l = last(recs);
        if (!recs.some((r) => r.center_of_mass_height_se != null))
          return { labels: ['centre of mass'], cols: [h] };
        // ensembles: the mean over the replicas with its standard error (docs/scene.md)
        const se = recs.map((r) => fin(r.center_of_mass_height_se));
        return { labels: ['centre of mass', '+ se', '\u2212 se'], cols: [h, h.map((v, i) => (v != null && se[i] != null ? v + se[i] : null)),
          h.map((v, i) => (v != null && se[i] != null ? v - se[i] : null))], dash: [undefined, [4, 3], [4, 3]],
          info: 'mean over ' + l.replicas + ' replicas; last: ' + fmt(l.center_of_mass_height) + ' \u00b1 ' + fmt(l.center_of_mass_height_se) };
      } },
    { id: 'energies', ylabel: 'energy', shown: (o) => o.includes('potential_energy') || o.includes('rotational_energy'),
      lines(recs, sc) {
        const o = (sc.output && sc.output.observables) || [];
        const parts = [['E_kin', 'kinetic_energy', o.includes('kinetic_energy') || o.includes('temperature')],
          ['E_pot', 'potential_energy', o.includes('potential_energy')], ['E_rot', 'rotational_energy', o.includes('rotational_energy')]]
          .filter((p) => p[2]);
        const labels = parts.map((p) => p[0]), cols = parts.map((p) => recs.map((r) => fin(r[p[1]])));
        if (parts.length > 1) {
          labels.push('sum');
          cols.push(recs.map((r, i) => { const v = cols.reduce((a, c) => a + c[i], 0); return Number.isFinite(v) ? v : null; }));
        }
        return { labels, cols, dash: labels.map((l) => (l === 'sum' ? [6, 4] : undefined)),
          info: parts.length > 1 ? 'sum: conserved when collisions are elastic (restitution 1' + (o.includes('rotational_energy') ? ', tangential_restitution \u00b11)' : ')') : '' };
      } },
    { id: 'msd', ylabel: 'MSD', log: true, shown: (o) => o.includes('mean_square_displacement'),
      lines(recs) {
        const m = recs.map((r) => fin(r.msd)), se = recs.map((r) => fin(r.msd_se));
        return { labels: ['MSD', 'MSD + se', 'MSD \u2212 se'], cols: [m, m.map((v, i) => (v != null && se[i] != null ? v + se[i] : null)),
          m.map((v, i) => (v != null && se[i] != null ? v - se[i] : null))], dash: [undefined, [4, 3], [4, 3]] };
      } },
    { id: 'flux', ylabel: 'flux', shown: (o) => o.includes('flux'),
      lines(recs) {
        const f = recs.map((r) => fin(r.flux)), se = recs.map((r) => fin(r.flux_se)), l = last(recs);
        return { labels: ['flux', 'flux + se', 'flux \u2212 se'], cols: [f, f.map((v, i) => (v != null && se[i] != null ? v + se[i] : null)),
          f.map((v, i) => (v != null && se[i] != null ? v - se[i] : null))], dash: [undefined, [4, 3], [4, 3]],
          info: Number.isFinite(l.flux) ? 'last: ' + fmt(l.flux) + ' \u00b1 ' + fmt(l.flux_se) : '' };
      } },
    { id: 'diffusion', ylabel: 'D(t)', shown: (o) => o.includes('mean_square_displacement'),
      lines(recs) {
        const l = last(recs);
        return { labels: ['D(t)'], cols: [recs.map((r) => fin(r.diffusion))], info: Number.isFinite(l.diffusion) ? 'last: ' + fmt(l.diffusion) + ' (the self-diffusion coefficient once t spans many collision times)' : '' };
      } },
  ];
  let obsPlots = {};   // panel id -> {key: its series labels, plot}
  const logValues = (u, vals) => vals.map((v) => (v == null ? '' : v >= 0.01 && v < 1e4 ? String(+v.toPrecision(3)) : v.toExponential(0)));
  function obsPlot(spec, labels, dash) {
    const node = $('plot-' + spec.id);
    const w = Math.max(380, node.clientWidth || 420);
    return new uPlot({
      width: w, height: 240, scales: { x: { time: false, distr: spec.log ? 3 : 1 }, y: { distr: spec.log ? 3 : 1 } },
      axes: [{ label: 'time' }, Object.assign({ label: spec.ylabel }, spec.log ? { values: logValues } : {})],
      series: [{ label: 't' }].concat(labels.map((l, k) => Object.assign({ label: l, stroke: COLORS[k % COLORS.length], width: 2, points: { show: false } },
        dash && dash[k] ? { dash: dash[k], width: 1.5 } : {}))),
    }, [[]].concat(labels.map(() => [])), node);
  }
  // The series change with the records (a wall's first outflow, more obstacles): a plot whose labels changed is rebuilt.
  function drawObs() {
    if (!series || !series.panels) return;
    for (const spec of series.panels) {
      const l = spec.lines(series.recs, series.scene);
      let x = series.t, cols = l.cols, labels = l.labels;
      if (!labels.length) { labels = [spec.ylabel]; cols = [x.map(() => null)]; }
      if (spec.log) {
        const keep = x.map((t) => t > 0);
        x = x.filter((_, i) => keep[i]);
        cols = cols.map((c) => c.filter((_, i) => keep[i]).map(pos));
      }
      $('plot-' + spec.id + '-nodata').hidden = !series.loaded || cols.some((c) => c.some(Number.isFinite));
      $('plot-' + spec.id + '-info').textContent = l.info || '';
      if (!window.uPlot) continue;
      const key = labels.join('\n');
      let o = obsPlots[spec.id];
      if (!o || o.key !== key) { if (o) o.plot.destroy(); o = obsPlots[spec.id] = { key, plot: obsPlot(spec, labels, l.dash) }; }
      o.plot.setData([x].concat(cols));
    }
  }
  const fetchSeries = throttle(async () => {
    if (!series) return;
    const id = series.job, s = series;
    try {
      const r = await api('GET', '/api/v1/jobs/' + id + '/progress?after=' + series.after);
      // the same page, not a later visit of the same job (whose series starts again)
      if (series !== s) return;
      series.loaded = true;
      setError('job-msg', 'series', '');
      for (const rec of r.records) {
        // A fetch can start while the previous one is still waiting for its answer (a slow daemon): both then
        // bring the same records, and the second must not append them again.
        if (rec.seq <= series.after) continue;
        series.after = rec.seq;
        if (rec.type !== 'progress') continue;
        series.t.push(rec.time); series.T.push(rec.temperature ?? null);
        series.Trot.push(rec.rotational_temperature ?? null);
        series.recs.push(rec);
        series.rate.push(rec.collision_rate ?? null);
        series.cl.push(rec.clusters ? rec.clusters.largest_fraction : null);
        if (Number.isFinite(rec.ranks)) renderSplit(rec);
      }
      drawPlots();
      if (!series.sceneP) series.sceneP = loadScene(id);   // once per job (retried after a failure)
      await series.sceneP;
      fetchCurves();
    } catch (e) { if (series === s) setError('job-msg', 'series', 'progress: ' + e.message); }
  }, 500);
  // ---- curves at snapshot times: the last sample of DIR/observables.jsonl (docs/output.md) ----
  let curvePlots = [], curvesAt = 0, curvesTimer = null;
  function curvePlot(node, label, logx, logy, extra, xlabel) {
    const w = Math.max(380, node.clientWidth || 420);
    return new uPlot({
      width: w, height: 240, scales: { x: { time: false, distr: logx ? 3 : 1 }, y: { distr: logy ? 3 : 1 } },
      axes: [{ label: xlabel || '' }, logy ? { values: (u, vals) => vals.map((v) => (v == null ? '' : v >= 0.01 && v < 1e4 ? String(+v.toPrecision(3)) : v.toExponential(0))) } : {}],
      series: [{}, { label, stroke: '#2f6fde', width: 2, points: { show: false } }].concat(extra || []),
    }, [[], []].concat((extra || []).map(() => [])), node);
  }
  const pos = (v) => (v > 0 ? v : null);   // log scales: no zeros
  const SK_HISTORY = 4;
  let skHistory = [];
  const CURVE_OBS = ['velocity_distribution', 'pair_correlation', 'structure_factor', 'clusters', 'impact_parameter', 'density_spectrum', 'surface_profile', 'fields'];
  // ---- fields (output.fields): a heat map of one quantity on the grid, 3D grids averaged over z ----
  let fieldsLast = null;
  function fieldColour(f) {   // a blue-green-yellow ramp (viridis-like) for f in [0, 1]
    const stops = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
    const x = Math.min(Math.max(f, 0), 1) * (stops.length - 1), k = Math.min(Math.floor(x), stops.length - 2), r = x - k;
    return 'rgb(' + stops[k].map((c, i) => Math.round(c + r * (stops[k + 1][i] - c))).join(',') + ')';
  }
  function drawFields() {
    const smp = fieldsLast;
    if (!smp) return;
    const tab = (sub) => smp.tables.find((t) => t.table === sub);
    const dens = tab('density'), vel = tab('velocity'), temp = tab('temperature'), spin = tab('spin');
    if (!dens || !dens.shape) return;
    const q = $('fields-q');
    q.querySelector('option[value=w]').hidden = !spin;
    if (q.value === 'w' && !spin) q.value = 'n';
    const [nx, ny] = dens.shape, nz = dens.shape[2] || 1, nc = nx * ny;
    let cell;   // the value of flat cell index c
    if (q.value === 'speed') cell = (c) => Math.hypot(...Object.values(vel.columns).map((u) => u[c]));
    else if (q.value === 'T') cell = (c) => temp.columns.T[c];
    else if (q.value === 'w') cell = (c) => Math.hypot(...Object.values(spin.columns).map((w) => w[c]));
    else cell = (c) => dens.columns.n[c];
    const v = new Array(nc).fill(0), k = new Array(nc).fill(0);
    for (let z = 0; z < nz; z++)
      for (let c = 0; c < nc; c++) {
        const x = cell(c + nc * z);
        if (x != null && Number.isFinite(x)) { v[c] += x; k[c]++; }
      }
    const val = v.map((x, c) => (k[c] ? x / k[c] : null)), fin = val.filter((x) => x != null);
    const lo = fin.length ? Math.min(...fin) : 0, hi = fin.length ? Math.max(...fin) : 1;
    const cv = $('fields-map'), ctx = cv.getContext('2d');
    const box = (series && series.scene && series.scene.particles && series.scene.particles.box) || [1, 1];
    // the box's aspect ratio, at most 480 px high
    const ratio = box[1] / box[0];
    let W = Math.max(320, cv.parentNode.clientWidth - 30 || 480), H = Math.round(W * ratio);
    if (H > 480) { H = 480; W = Math.max(80, Math.round(H / ratio)); }
    H = Math.max(80, H);
    if (cv.width !== W || cv.height !== H) { cv.width = W; cv.height = H; }
    ctx.clearRect(0, 0, W, H);
    for (let j = 0; j < ny; j++)
      for (let i = 0; i < nx; i++) {
        const x = val[i + nx * j];
        ctx.fillStyle = x == null ? '#c8ccd4' : fieldColour(hi > lo ? (x - lo) / (hi - lo) : 0.5);
        const x0 = Math.floor(i * W / nx), x1 = Math.floor((i + 1) * W / nx);
        const y0 = Math.floor(H - (j + 1) * H / ny), y1 = Math.floor(H - j * H / ny);
        ctx.fillRect(x0, y0, x1 - x0, y1 - y0);
      }
    const name = q.options[q.selectedIndex].textContent;
    $('fields-info').textContent = name + ' from ' + (+lo.toPrecision(4)) + ' (dark) to ' + (+hi.toPrecision(4)) +
      ' (bright) on ' + dens.shape.join(' x ') + ' cells' + (nz > 1 ? ' (mean over z)' : '') + ', sample ' + smp.sample +
      ' at time ' + (+smp.time.toPrecision(4)) + ', ' + smp.samples + ' instant' + (smp.samples === 1 ? '' : 's') +
      (fin.length < nc ? '; grey: empty cells' : '');
  }
  async function fetchCurves() {
    if (!series || !window.uPlot) return;
    const id = series.job, now = Date.now();
    // the engine creates the file before its first progress record
    if (!series.curves || !series.curves.length || !series.t.length) return;
    if (now - curvesAt < 5000) {   // at most every 5 s (the file grows), but always once more after the last call
      if (!curvesTimer) curvesTimer = setTimeout(() => { curvesTimer = null; fetchCurves(); }, 5000 - (now - curvesAt));
      return;
    }
    curvesAt = now;
    // the last sample of each family: GET /api/v1/jobs/{id}/observables?name=...&last=1 (docs/daemon.md)
    const last = {};
    try {
      for (const name of series.curves) {
        // S(k) over time: the last SK_HISTORY samples (the growth of clusters shows at small k)
        const k = name === 'structure_factor' ? SK_HISTORY : 1;
        const r = await api('GET', '/api/v1/jobs/' + id + '/observables?name=' + name + '&last=' + k);
        if (r.samples.length) last[name] = r.samples[r.samples.length - 1];
        if (name === 'structure_factor') skHistory = r.samples;
      }
    } catch (e) { return; }
    if (!series || series.job !== id) return;
    const tab = (name, sub) => (last[name] ? last[name].tables.find((t) => t.table === sub) : null);
    const sp = tab('velocity_distribution', 'speed'), comp = tab('velocity_distribution', 'components');
    const g = tab('pair_correlation', ''), sk = tab('structure_factor', '');
    // mixtures: the partial g_ab(r) of each pair of species and their contact values (docs/output.md)
    const gs = tab('pair_correlation', 'species'), gc = tab('pair_correlation', 'contact');
    const gcols = gs ? Object.keys(gs.columns) : [];
    const ns = tab('clusters', ''), pb = tab('impact_parameter', ''), ds = tab('density_spectrum', '');
    const sf = tab('surface_profile', '');
    if (last.fields) {
      fieldsLast = last.fields;
      $('fields').hidden = false;
      drawFields();
    }
    if (!sp && !g && !sk && !ns && !pb && !ds && !sf) return;
    $('curves').hidden = false;
    if (!curvePlots.length) {
      curvePlots = [
        curvePlot($('plot-vdist'), 'P(c)', false, true, [{ label: 'Maxwellian', stroke: '#d2691e', dash: [6, 4], width: 1.5, points: { show: false } }], 'c'),
        curvePlot($('plot-gofr'), 'g(r)', false, false, gcols.map((c, j) => ({ label: c, stroke: ['#d2691e', '#2e8b57', '#8a2be2', '#b22222', '#708090', '#daa520', '#20b2aa', '#ff69b4', '#556b2f', '#4682b4'][j % 10], width: 1, points: { show: false } })), 'r'),
        curvePlot($('plot-sofk'), 'S(k)', true, true, [1, 2, 3].map((j) => ({ label: j + ' earlier', stroke: 'rgba(47,111,222,' + (0.6 - 0.15 * j) + ')', width: 1, points: { show: false } })), 'k'),
        curvePlot($('plot-clusters'), 'n_s', true, true, [{ label: 'fit s^-τ', stroke: '#d2691e', dash: [6, 4], width: 1.5, points: { show: false } }], 's'),
        curvePlot($('plot-impact'), 'P(b)', false, false, [{ label: 'molecular chaos', stroke: '#d2691e', dash: [6, 4], width: 1.5, points: { show: false } }], 'b/σ'),
        curvePlot($('plot-dspec'), 'P(f)', true, true, [{ label: 'fit f^α', stroke: '#d2691e', dash: [6, 4], width: 1.5, points: { show: false } }], 'f'),
        curvePlot($('plot-surface'), 'h(x)', false, false, [], 'x'),
      ];
    }
    const D = series.dim || (comp ? Object.keys(comp.columns).length : 2);
    if (sp) {
      const mw = sp.centres.map((c) => pos(D === 2 ? 2 * c * Math.exp(-c * c) : 4 / Math.sqrt(Math.PI) * c * c * Math.exp(-c * c)));
      curvePlots[0].setData([sp.centres, sp.columns.p.map(pos), mw]);
    }
    if (g) curvePlots[1].setData([g.centres, g.columns.g].concat(gcols.map((c) => (gs && gs.columns[c] ? gs.columns[c] : g.centres.map(() => null)))));
    if (sk) {
      // the latest sample, then up to three earlier ones (same shells: the grid is fixed by the scene)
      const older = [2, 3, 4].map((j) => {
        const smp = skHistory[skHistory.length - j], t = smp && smp.tables.find((x) => x.table === '');
        return t && t.columns.s.length === sk.columns.s.length ? t.columns.s.map(pos) : sk.centres.map(() => null);
      });
      curvePlots[2].setData([sk.centres, sk.columns.s.map(pos)].concat(older));
    }
    if (ns) {
      // the power law n_s ~ s^-exponent (engine fit, sizes >= 2), drawn through the first sampled size >= 2
      const tau = last.clusters.exponent, y = ns.columns.n_s;
      const k0 = ns.centres.findIndex((s, k) => s >= 2 && y[k] > 0);
      let k1 = y.length - 1;
      while (k1 > 0 && !(y[k1] > 0)) k1--;   // over the sizes present only
      const fit = ns.centres.map((s, k) => (Number.isFinite(tau) && k0 >= 0 && k >= k0 && k <= k1 ? pos(y[k0] * Math.pow(s / ns.centres[k0], -tau)) : null));
      curvePlots[3].setData([ns.centres, y.map(pos), fit]);
    }
    if (pb) curvePlots[4].setData([pb.centres, pb.columns.p, pb.centres.map((b) => (D === 2 ? 1 : 2 * b))]);
    if (ds) {
      // the engine's slope alpha drawn through the mean of log f and log P over the fit range (output.density_spectrum.fit)
      const sc = (series.scene && series.scene.output && series.scene.output.density_spectrum) || {};
      const [lo, hi] = sc.fit || [0, Infinity], a = last.density_spectrum.alpha, P = ds.columns.P;
      const inr = ds.centres.map((f, k) => f >= lo && f <= hi && P[k] > 0);
      const n = inr.filter((x) => x).length;
      const mf = ds.centres.reduce((s, f, k) => s + (inr[k] ? Math.log(f) : 0), 0) / n;
      const mp = P.reduce((s, p, k) => s + (inr[k] ? Math.log(p) : 0), 0) / n;
      const fit = ds.centres.map((f, k) => (Number.isFinite(a) && n && inr[k] ? Math.exp(mp + a * (Math.log(f) - mf)) : null));
      curvePlots[5].setData([ds.centres, P.map(pos), fit]);
    }
    if (sf) curvePlots[6].setData([sf.centres, sf.columns.h]);   // empty bins are null: gaps
    const info = [];
    const any = CURVE_OBS.filter((n) => n !== 'fields').map((n) => last[n]).find((x) => x);
    info.push('sample ' + any.sample + ' at time ' + (+any.time.toPrecision(4)));
    if (last.velocity_distribution) info.push('a2 = ' + (last.velocity_distribution.a2 ?? NaN).toPrecision(3));
    if (last.velocity_distribution && last.velocity_distribution.a2_spin !== undefined)
      info.push('spins: a2 = ' + (last.velocity_distribution.a2_spin ?? NaN).toPrecision(3) + ', T_rot = ' + (last.velocity_distribution.temperature_rot ?? NaN).toPrecision(4));
    if (last.pair_correlation && gc && gcols.length)
      info.push('contact values ' + gcols.map((c, k) => c + '(σ) = ' + (gc.columns.g[k] ?? NaN).toPrecision(4)).join(', '));
    else if (last.pair_correlation) info.push('g(σ) = ' + (last.pair_correlation.g_contact_pairs ?? NaN).toPrecision(4));
    if (last.clusters) info.push('n_s exponent τ = ' + (last.clusters.exponent ?? NaN).toPrecision(3) + ', w = ' + (last.clusters.w ?? NaN).toPrecision(3));
    if (pb) info.push('P(b) of ' + pb.columns.n.reduce((a, x) => a + x, 0) + ' collisions since the previous sample');
    if (sk && skHistory.length > 1) info.push('S(k) at times ' + skHistory.map((x) => +x.time.toPrecision(3)).join(', ') + ' (latest bold)');
    if (ds) info.push('density spectrum slope α = ' + (last.density_spectrum.alpha ?? NaN).toPrecision(3) + ' \u00b1 ' + (last.density_spectrum.alpha_se ?? NaN).toPrecision(2) + ' over ' + last.density_spectrum.samples + ' samples');
    $('curves-info').textContent = info.join(', ');
  }
  // Nothing of the job shown before may stay on the page of the next one.
  function clearJobPage(id) {
    $('job-id').textContent = id;
    const b = $('job-state'); b.className = 'badge'; b.textContent = '';
    $('job-bar').style.width = '0%';
    $('job-cancel').hidden = true;
    $('job-info').replaceChildren();
    clearErrors('job-msg');
    renderJobAdvice({});
    renderSplit(null);
    $('haff').textContent = '';
    for (const t of ['job-attempts', 'job-files']) { $(t).tBodies[0].replaceChildren(); $(t).hidden = true; }
    $('job-attempts-none').hidden = true; $('job-files-none').hidden = true;
    for (const p of curvePlots) p.destroy();
    curvePlots = []; skHistory = []; curvesAt = 0; $('curves').hidden = true; $('curves-info').textContent = '';
    fieldsLast = null; $('fields').hidden = true; $('fields-info').textContent = '';
    for (const o of Object.values(obsPlots)) o.plot.destroy();
    obsPlots = {};
    for (const p of OBS_PANELS) { $('panel-' + p.id).hidden = true; $('plot-' + p.id + '-info').textContent = ''; }
    $('trot-title').hidden = true;
  }
  async function openJob(id) {
    view.job = id;
    $('list-view').hidden = true; $('job-view').hidden = false;
    clearJobPage(id);
    series = { job: id, after: -1, t: [], T: [], Trot: [], rate: [], cl: [], recs: [], loaded: false };
    makePlots();
    drawPlots();
    await loadJob(id);
    fetchSeries();
  }
  function route() {
    const m = location.hash.match(/^#\/job\/(\d+)$/);
    if (m) { openJob(Number(m[1])); return; }
    view.job = 0; series = null;
    $('job-view').hidden = true; $('list-view').hidden = false;
    setError('jobs-msg', 'cancel', '');
    renderJobs();
  }

  // ---- the one event stream ----
  // fetch() rather than EventSource: EventSource cannot send the Authorization header, and with
  // read_auth token the stream needs it. Reconnects itself, resuming with Last-Event-ID.
  const handlers = {
    hello: () => { loadJobs(); loadCluster(); if (view.job) fetchSeries(); },
    state: (data) => {
      const j = JSON.parse(data);
      jobs.set(j.id, Object.assign(jobs.get(j.id) || {}, j));
      renderJobs(); loadCluster();
      if (view.job === j.id) { renderJob(jobs.get(j.id)); fetchSeries(); loadJob(j.id); }
    },
    // Progress lines do not name their job: refresh what is on screen, throttled.
    progress: () => { refreshActive(); if (view.job) fetchSeries(); },
    deleted: () => loadJobs(),
    gap: () => loadJobs(),
  };
  let stream = null, lastEventId = '', retryMs = 2000;
  function liveBadge(cls, text) { const live = $('live'); live.className = 'badge ' + cls; live.textContent = text; }
  function dispatch(block) {
    let type = 'message', data = [], id = null;
    for (const line of block.split('\n')) {
      if (!line || line[0] === ':') continue;
      const k = line.indexOf(':');
      const f = k < 0 ? line : line.slice(0, k);
      const v = k < 0 ? '' : line.slice(k + 1).replace(/^ /, '');
      if (f === 'event') type = v;
      else if (f === 'data') data.push(v);
      else if (f === 'id') id = v;
      else if (f === 'retry' && /^\d+$/.test(v)) retryMs = Number(v);
    }
    if (id !== null) lastEventId = id;
    if (type === 'hello') liveBadge('live', 'live');
    if (handlers[type] && (data.length || type === 'hello')) handlers[type](data.join('\n'));
  }
  async function connect() {
    const ctl = new AbortController();
    if (stream) stream.abort();
    stream = ctl;
    const headers = Object.assign({ Accept: 'text/event-stream' }, authHeaders());
    if (lastEventId) headers['Last-Event-ID'] = lastEventId;
    try {
      const r = await fetch('/api/v1/events', { headers, signal: ctl.signal, cache: 'no-store' });
      if (r.status === 401) { liveBadge('down', 'token needed'); return; }   // the token form reconnects
      if (!r.ok || !r.body) throw new Error('HTTP ' + r.status);
      const reader = r.body.getReader(), dec = new TextDecoder();
      let buf = '';
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        buf += dec.decode(value, { stream: true }).replace(/\r\n?/g, '\n');
        let e;
        while ((e = buf.indexOf('\n\n')) >= 0) { dispatch(buf.slice(0, e)); buf = buf.slice(e + 2); }
      }
    } catch (err) {
      if (ctl.signal.aborted) return;
    }
    if (stream !== ctl) return;
    liveBadge('down', 'reconnecting');
    setTimeout(() => { if (stream === ctl) connect(); }, retryMs);
  }

  // ---- token: entered once, kept in localStorage ----
  function showToken() { $('token-state').textContent = localStorage.getItem(TOKEN_KEY) ? 'saved' : 'none (needed to submit/cancel, and to read where the daemon asks)'; }
  $('token-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    const v = $('token').value.trim();
    if (v) localStorage.setItem(TOKEN_KEY, v); else localStorage.removeItem(TOKEN_KEY);
    $('token').value = ''; showToken();
    lastEventId = ''; loadPresets(); loadJobs(); loadCluster(); connect();
  });

  $('preset').addEventListener('change', showPreset);
  $('fields-q').addEventListener('change', drawFields);
  for (const id of ['scene', 'priority', 'ranks']) $(id).addEventListener('input', formChanged);
  $('submit-form').addEventListener('submit', submit);
  $('advise').addEventListener('click', advise);
  $('filter').addEventListener('change', renderJobs);
  $('job-cancel').addEventListener('click', () => view.job && cancel(view.job, $('job-state').textContent));
  window.addEventListener('hashchange', route);
  showToken(); loadPresets(); loadJobs(); loadCluster(); route(); connect();
  setInterval(loadCluster, 10000);
})();
