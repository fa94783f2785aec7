// Dashboard in a real browser: headless Chromium (playwright-core) against a live granulard; submits a preset,
// follows the job to the end, checks the plots received data, saves a screenshot; asks for advice on the preset
// (the candidates table) and shows an auto job's advice panel; the job page's files and attempts, "no data" on
// an empty plot, nothing stale kept (advice, errors, another job's page), and a confirmation before cancelling;
// the compute-cluster panel's launcher, and (on answers put in by the browser) its Slurm partition and the attempts' Slurm jobs;
// the progress panels of a scene with walls, gravity, an obstacle, an open wall and rough particles (pressure per wall, drag
// and lift, outflow, height, energies, T_rot beside T) and of a periodic one (MSD and D(t) only). With a 4th argument "read-auth-token" (a daemon run
// with --read-auth token): the page asks for the token, then lists jobs and follows the event stream with it.
'use strict';
const { chromium } = require('playwright-core');
const [url, token, shot, mode] = process.argv.slice(2);
let n = 0, failed = 0;
const ok = (c, d) => { n++; if (!c) failed++; console.log(`${c ? '' : 'not '}ok ${n} - ${d}`); };
// Pixels of a series colour (default the first series' #2f6fde) on each plot's canvas: the plot drew data.
const pixels = (page, ids, rgb) => page.evaluate(([list, c]) => list.map((id) => {
  const cv = document.querySelector('#' + id + ' canvas');
  if (!cv) return 0;
  const d = cv.getContext('2d').getImageData(0, 0, cv.width, cv.height).data;
  let k = 0;
  for (let i = 0; i < d.length; i += 4) if (Math.abs(d[i] - c[0]) < 30 && Math.abs(d[i + 1] - c[1]) < 30 && Math.abs(d[i + 2] - c[2]) < 30 && d[i + 3] > 100) k++;
  return k;
}), [ids, rgb || [47, 111, 222]]);
// The progress panels of walls, gravity, obstacles, open walls, rough particles and diffusion (dashboard/app.js OBS_PANELS).
const OBS = ['walls', 'obstacles', 'outflow', 'height', 'energies', 'msd', 'diffusion'];
(async () => {
  const browser = await chromium.launch({
    executablePath: '/usr/bin/chromium',
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync'],
  });
  const page = await browser.newPage({ viewport: { width: 1280, height: 1000 } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  // A 404 the test asks for on purpose (an unknown job) is logged by Chromium as a failed resource, not a script error.
  page.on('console', (m) => { if (m.type() === 'error' && !/Failed to load resource.* 404/.test(m.text())) errors.push(m.text()); });
  if (mode === 'read-auth-token') {
    try {
      await page.goto(url + '/', { waitUntil: 'load' });
      await page.waitForFunction(() => document.getElementById('live').textContent === 'token needed', null, { timeout: 10000 });
      ok(true, 'read_auth token, no token saved: the live badge says the token is needed');
      await page.fill('#token', token);
      await page.click('#token-form button');
      await page.waitForFunction(() => document.getElementById('live').textContent === 'live', null, { timeout: 10000 });
      ok(true, 'token entered: the event stream (fetch with the Authorization header) is live');
      await page.waitForFunction(() => document.querySelectorAll('#preset option').length > 0, null, { timeout: 10000 });
      ok(true, 'token entered: presets load');
      await page.selectOption('#preset', 'cooling-2d');
      await page.click('#submit-form button[type=submit]');
      await page.waitForFunction(() => /^job \d+/.test(document.getElementById('submit-msg').textContent), null, { timeout: 10000 });
      const id = Number((await page.textContent('#submit-msg')).match(/^job (\d+)/)[1]);
      // The table learns the end of the job from the stream's state events only (no reload in between).
      await page.waitForFunction((i) => [...document.querySelectorAll('#jobs tbody tr')].some((r) => r.textContent.includes(String(i)) &&
        r.textContent.includes('succeeded')), id, { timeout: 120000 });
      ok(true, 'job ' + id + ' followed to succeeded in the live table');
      // A file link: with the token saved the download goes through fetch() with the header.
      await page.evaluate((i) => { location.hash = '#/job/' + i; }, id);
      await page.waitForFunction(() => document.querySelectorAll('#job-files tbody tr a').length > 0, null, { timeout: 10000 });
      const [dl] = await Promise.all([page.waitForEvent('download', { timeout: 10000 }), page.click('#job-files tbody tr a')]);
      const size = require('fs').statSync(await dl.path()).size;
      ok(size > 0 && !dl.url().includes(token), 'job file ' + dl.suggestedFilename() + ' downloaded with the token header (' + size + ' bytes)');
      ok(!(await page.evaluate(() => location.href)).includes(token), 'the token is not in the URL');
      // The 401s before the token was entered are expected; nothing else may fail.
      const other = errors.filter((e) => !/401/.test(e));
      ok(other.length === 0, 'no script errors' + (other.length ? ': ' + other.join('; ') : ''));
    } catch (e) {
      ok(false, 'browser session (read_auth token): ' + e.message.split('\n')[0]);
    } finally {
      await browser.close();
    }
    console.log(`1..${n}`);
    process.exit(failed ? 1 : 0);
  }
  try {
    await page.goto(url + '/', { waitUntil: 'load' });
    ok(await page.title() !== '', 'dashboard loads: ' + await page.title());
    await page.fill('#token', token);
    await page.click('#token-form button');
    ok((await page.textContent('#token-state')).includes('saved'), 'token entered once and kept');
    ok(!(await page.evaluate(() => location.href)).includes(token), 'the token is not in the URL');
    await page.waitForFunction(() => document.querySelectorAll('#preset option').length > 0, null, { timeout: 10000 });
    await page.selectOption('#preset', 'cooling-2d');
    // Advice before submitting: the table of candidates for the preset (a concrete scene: no choice).
    await page.click('#advise');
    await page.waitForFunction(() => document.querySelectorAll('#advice tbody tr').length > 0, null, { timeout: 10000 });
    const variants = await page.$$eval('#advice tbody tr', (rs) => rs.map((r) => r.dataset.variant));
    const cells = await page.$$eval('#advice tbody tr', (rs) => rs.map((r) => r.children.length));
    ok(['ed', 'dsmc/none', 'dsmc/enskog', 'hsmc/cba'].every((v) => variants.includes(v)) && cells.every((c) => c === 7) &&
      !(await page.isHidden('#advice')), 'advice table for the preset: ' + variants.join(', '));
    // The structure observables too: their curves (observables.jsonl) get plots of their own.
    await page.evaluate(() => {
      const s = JSON.parse(document.getElementById('scene').value);
      s.output = s.output || {};
      s.output.observables = (s.output.observables || ['kinetic_energy', 'temperature', 'pressure', 'compressibility', 'collision_rate'])
        .concat(['velocity_distribution', 'pair_correlation', 'structure_factor', 'clusters', 'impact_parameter', 'fields'])
        .filter((o, k, a) => a.indexOf(o) === k);
      s.output.fields = { cells: [16, 16] };
      document.getElementById('scene').value = JSON.stringify(s);
    });
    await page.click('#submit-form button[type=submit]');
    await page.waitForFunction(() => /^job \d+/.test(document.getElementById('submit-msg').textContent), null, { timeout: 10000 });
    const msg = await page.textContent('#submit-msg');
    const id = Number(msg.match(/^job (\d+)/)[1]);
    ok(id > 0, 'preset submitted from the form: ' + msg);
    await page.waitForFunction((i) => [...document.querySelectorAll('#jobs tbody tr')].some((r) => r.textContent.includes(String(i))),
      id, { timeout: 10000 });
    ok(true, 'the job appears in the live job table');
    await page.evaluate((i) => { location.hash = '#/job/' + i; }, id);
    await page.waitForFunction(() => document.getElementById('job-state').textContent === 'succeeded', null, { timeout: 120000 });
    ok(true, 'the job page follows the job to succeeded');
    // Data reached the plots: pixels in the series colour (#2f6fde) on each canvas, and the Haff fit text.
    await page.waitForFunction(() => document.getElementById('haff').textContent.includes('tau'), null, { timeout: 10000 });
    const px = await page.evaluate(() => ['plot-energy', 'plot-rate', 'plot-cluster'].map((id) => {
      const c = document.querySelector('#' + id + ' canvas');
      if (!c) return 0;
      const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let k = 0;
      for (let i = 0; i < d.length; i += 4) if (Math.abs(d[i] - 47) < 30 && Math.abs(d[i + 1] - 111) < 30 && Math.abs(d[i + 2] - 222) < 30 && d[i + 3] > 100) k++;
      return k;
    }));
    ok(px[0] > 50, `temperature plot drew its series (${px[0]} px) with ${await page.textContent('#haff')}`);
    ok(px[1] > 50, `collision-rate plot drew its series (${px[1]} px)`);
    ok(px[2] > 50, `largest-cluster plot drew its series (${px[2]} px)`);
    await page.waitForFunction(() => !document.getElementById('curves').hidden &&
      /sample [1-9]/.test(document.getElementById('curves-info').textContent), null, { timeout: 15000 });
    const cpx = await page.evaluate(() => ['plot-vdist', 'plot-gofr', 'plot-sofk', 'plot-clusters', 'plot-impact'].map((id) => {
      const c = document.querySelector('#' + id + ' canvas');
      if (!c) return 0;
      const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let k = 0;
      for (let i = 0; i < d.length; i += 4) if (Math.abs(d[i] - 47) < 30 && Math.abs(d[i + 1] - 111) < 30 && Math.abs(d[i + 2] - 222) < 30 && d[i + 3] > 100) k++;
      return k;
    }));
    ok(cpx.every((k) => k > 50), `P(c), g(r), S(k), n_s, P(b) plots drew the last sample (${cpx.join(', ')} px): ${await page.textContent('#curves-info')}`);
    // S(k) over time: the last samples are fetched (the info line lists their times) and the plot has a series
    // for each earlier one (here sample 0 is the lattice start, whose S(k) is ~0 and not drawn on the log axis)
    const skInfo = await page.textContent('#curves-info'), skLegend = await page.textContent('#plot-sofk');
    ok(/S\(k\) at times [0-9.e+-]+, [0-9.e+-]+/.test(skInfo) && /1 earlier/.test(skLegend) && /3 earlier/.test(skLegend),
      `S(k) over time: ${skInfo.replace(/.*(S\(k\) at times[^)]*\)).*/, '$1')}; legend: ${skLegend}`);
    // Fields: a heat map of the 16 x 16 grid, each cell one colour of the ramp; the selector redraws it.
    const heat = () => page.evaluate(() => {
      const c = document.getElementById('fields-map'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      const colours = new Set();
      let painted = 0;
      for (let i = 0; i < d.length; i += 4) if (d[i + 3] > 200) { painted++; colours.add(d[i] + ',' + d[i + 1] + ',' + d[i + 2]); }
      return { painted: painted / (c.width * c.height), colours: colours.size, info: document.getElementById('fields-info').textContent };
    });
    const h1 = await heat();
    ok(!(await page.isHidden('#fields')) && h1.painted > 0.99 && h1.colours > 10 && /^number density .* 16 x 16 cells/.test(h1.info),
      `fields heat map: ${(100 * h1.painted).toFixed(1)}% of the canvas painted in ${h1.colours} colours: ${h1.info}`);
    await page.selectOption('#fields-q', 'T');
    const h2 = await heat();
    ok(h2.painted > 0.99 && /^temperature/.test(h2.info), `fields selector: temperature drawn: ${h2.info}`);
    await page.screenshot({ path: shot, fullPage: true });
    ok(true, 'screenshot saved: ' + shot);
    ok(!(await page.isVisible('#job-advice')), 'a job with a concrete method shows no advice panel');
    // Method auto: the job page shows the decision (chosen variant, reason) and the candidates.
    await page.evaluate(() => { location.hash = '#/'; });
    await page.waitForFunction(() => !document.getElementById('list-view').hidden, null, { timeout: 10000 });
    await page.evaluate(() => {
      const s = JSON.parse(document.getElementById('scene').value);
      s.method = 'auto'; s.accuracy = { temperature: 0.05 };
      document.getElementById('scene').value = JSON.stringify(s);
    });
    await page.click('#advise');
    await page.waitForFunction(() => /chosen: /.test(document.getElementById('advice').textContent), null, { timeout: 10000 });
    const chosenForm = (await page.textContent('#advice .reason')).match(/chosen: (\S+)/)[1];
    ok(await page.$('#advice tr.chosen') !== null, 'advise on an auto scene: chosen ' + chosenForm + ', its row marked');
    await page.click('#submit-form button[type=submit]');
    await page.waitForFunction((i) => (document.getElementById('submit-msg').textContent.match(/^job (\d+)/) || [])[1] > i, id,
      { timeout: 10000 });
    const aid = Number((await page.textContent('#submit-msg')).match(/^job (\d+)/)[1]);
    await page.evaluate((i) => { location.hash = '#/job/' + i; }, aid);
    await page.waitForFunction(() => !document.getElementById('job-advice').hidden && document.querySelectorAll('#job-advice tbody tr').length > 0,
      null, { timeout: 10000 });
    const reason = await page.textContent('#job-advice .reason');
    ok(reason.includes('chosen: ' + chosenForm) && reason.includes('cheapest') &&
      (await page.$$eval('#job-advice tbody tr', (rs) => rs.length)) >= 4, 'auto job ' + aid + ': advice panel: ' + reason.slice(0, 90));

    // The job page lists the job's files (links that download them) and its attempts.
    await page.evaluate((i) => { location.hash = '#/job/' + i; }, id);
    await page.waitForFunction(() => document.querySelectorAll('#job-files tbody tr').length > 0 &&
      document.querySelectorAll('#job-attempts tbody tr').length > 0, null, { timeout: 10000 });
    const files = await page.$$eval('#job-files tbody tr', (rs) => rs.map((r) => r.dataset.name));
    const href = await page.getAttribute('#job-files tr[data-name="scene.json"] a', 'href');
    const fetched = href ? await page.evaluate(async (h) => (await fetch(h)).json(), href) : null;
    ok(files.includes('scene.json') && files.includes('progress.jsonl') && fetched && fetched.method === 'ed',
      'job ' + id + ' page lists its files, each a download link: ' + files.join(', '));
    const attempts = await page.$$eval('#job-attempts tbody tr', (rs) => rs.map((r) => r.textContent));
    ok(attempts.length === 1 && /exit 0/.test(attempts[0]) && await page.isHidden('#job-attempts-none'),
      'and its attempts: ' + attempts.join(' | '));

    // Another job's page keeps nothing of this one; an error goes when the next page loads fine.
    await page.evaluate(() => { location.hash = '#/job/999999'; });
    await page.waitForFunction(() => /not found/.test(document.getElementById('job-msg').textContent), null, { timeout: 10000 });
    const stale = await page.evaluate(() => ({
      id: document.getElementById('job-id').textContent, info: document.getElementById('job-info').textContent,
      files: document.querySelectorAll('#job-files tbody tr').length, attempts: document.querySelectorAll('#job-attempts tbody tr').length,
      state: document.getElementById('job-state').textContent,
    }));
    ok(stale.id === '999999' && stale.info === '' && stale.files === 0 && stale.attempts === 0 && stale.state === '' &&
      await page.isVisible('#job-msg'), 'an unknown job\'s page shows its error and nothing of job ' + id + ': ' + JSON.stringify(stale));
    await page.evaluate((i) => { location.hash = '#/job/' + i; }, id);
    await page.waitForFunction(() => document.getElementById('job-state').textContent === 'succeeded', null, { timeout: 10000 });
    ok(await page.isHidden('#job-msg') && (await page.textContent('#job-msg')) === '', 'the error is gone on the next job\'s page');

    // The compute-cluster panel names the launcher: this daemon's is mpirun, the default.
    const dd = (key) => page.evaluate((k) => {
      const t = [...document.querySelectorAll('#cluster-stats dt')].find((d) => d.textContent === k);
      return t ? t.nextElementSibling.textContent : null;
    }, key);
    const launcher = await dd('launcher');
    ok(launcher === 'mpirun' && (await dd('partition')) === null, 'cluster panel: launcher ' + launcher + ', no partition rows');
    // With launcher = slurm (no Slurm here: tests/slurm_test.sh runs a real one and checks the API): the answers such a
    // daemon gives, put in by the browser (page.route) on this daemon's own, and how the page renders them.
    const real = await page.evaluate(async () => (await fetch('/api/v1/cluster')).json());
    const slurm = { partition: 'gtest', nodes: { total: 3, idle: 1, allocated: 2, mixed: 0, other: 0 },
      cpus: { allocated: 8, idle: 4, other: 0, total: 12 }, pending_jobs: 5 };
    await page.route(url + '/api/v1/cluster', (r) => r.fulfill({ contentType: 'application/json',
      body: JSON.stringify(Object.assign({}, real, { launcher: 'slurm', slurm })) }));
    await page.route(url + '/api/v1/jobs/' + id + '?scene=0', async (r) => {
      const resp = await r.fetch(), j = await resp.json();
      j.attempts = j.attempts.map((a) => Object.assign({}, a, { pid: null, slurm_job: 4242, slurm_state: 'completed' }));
      await r.fulfill({ response: resp, body: JSON.stringify(j) });
    });
    await page.reload({ waitUntil: 'load' });
    await page.waitForFunction(() => /gtest/.test(document.getElementById('cluster-stats').textContent) &&
      /Slurm job/.test(document.getElementById('job-attempts').textContent), null, { timeout: 10000 });
    const sl = { launcher: await dd('launcher'), partition: await dd('partition'), nodes: await dd('nodes'), cpus: await dd('CPUs'),
      pending: await dd('pending') };
    ok(sl.launcher === 'slurm' && sl.partition === 'gtest, 3 nodes' && sl.nodes === '1 idle, 2 allocated' &&
      sl.cpus === '4 idle, 8 allocated of 12' && sl.pending === '5 Slurm jobs', 'cluster panel with Slurm: ' + JSON.stringify(sl));
    const sa = await page.$$eval('#job-attempts tbody tr', (rs) => rs.map((r) => r.textContent));
    ok(sa.length === 1 && /exit 0/.test(sa[0]) && sa[0].includes('Slurm job 4242: completed'), 'attempts with Slurm: ' + sa.join(' | '));
    await page.unroute(url + '/api/v1/cluster');
    await page.unroute(url + '/api/v1/jobs/' + id + '?scene=0');

    // A scene with walls, gravity, an obstacle, an open wall and rough particles: the job page adds a panel for each
    // of their progress series, and T_rot beside T. Their data are the job's records (/progress), drawn.
    const submitScene = async (scene, after) => {
      await page.evaluate(() => { location.hash = '#/'; });
      await page.waitForFunction(() => !document.getElementById('list-view').hidden, null, { timeout: 10000 });
      await page.fill('#scene', JSON.stringify(scene));
      await page.click('#submit-form button[type=submit]');
      await page.waitForFunction((i) => (document.getElementById('submit-msg').textContent.match(/^job (\d+)/) || [])[1] > i, after,
        { timeout: 10000 });
      const jid = Number((await page.textContent('#submit-msg')).match(/^job (\d+)/)[1]);
      await page.evaluate((i) => { location.hash = '#/job/' + i; }, jid);
      await page.waitForFunction(() => document.getElementById('job-state').textContent === 'succeeded', null, { timeout: 60000 });
      return jid;
    };
    // Slow answers to /progress (1.5 s): the page asks again while its first request waits; no record may be drawn twice.
    await page.route('**/progress?*', async (route) => { await new Promise((r) => setTimeout(r, 1500)); await route.continue().catch(() => {}); });
    const wid = await submitScene({ method: 'ed', dimensions: 2,
      particles: { count: 800, box: [80, 40], initial: { positions: 'random', temperature: 0.5, velocity: [0.5, 0] } },
      collisions: { restitution: 0.9, tc: 0.001, rough: { tangential_restitution: 0.4, friction: 0.3 } }, gravity: [0, -0.01],
      boundaries: { x: { type: 'walls', lower: { type: 'specular' }, upper: { type: 'open' } },
        y: { type: 'walls', lower: { type: 'specular' }, upper: { type: 'specular' } } },
      obstacles: [{ type: 'random_sign', center: [40, 20], radius: 5 }], run: { seed: 3, until: { time: 100 } },
      output: { every: { time: 10 }, observables: ['temperature', 'rotational_temperature', 'rotational_energy', 'outflow', 'obstacle_force',
        'wall_force', 'center_of_mass_height', 'potential_energy'] } }, aid);
    const recs = (await page.evaluate(async (i) => (await (await fetch('/api/v1/jobs/' + i + '/progress')).json()), wid))
      .records.filter((r) => r.type === 'progress');
    const lastRec = recs[recs.length - 1];
    // The last records arrive after the final state: wait until the outflow panel names the last one's count.
    await page.waitForFunction((c) => document.getElementById('plot-outflow-info').textContent.startsWith(c + ' particles present'),
      String(lastRec.particles_present), { timeout: 10000 }).catch(() => {});
    await page.waitForTimeout(3000);   // and any request still delayed
    await page.unroute('**/progress?*');
    const drawn = Number(await page.getAttribute('#plot-energy', 'data-records'));
    ok(drawn === recs.length, 'job ' + wid + ' with slow /progress answers: ' + drawn + ' records drawn, ' + recs.length + ' stored');
    const shown = await page.evaluate((ids) => ids.map((id) => !document.getElementById('panel-' + id).hidden), OBS);
    ok(JSON.stringify(shown) === JSON.stringify([true, true, true, true, true, false, false]) && await page.isHidden('#curves'),
      'job ' + wid + ' (walls, gravity, obstacle, open wall, rough): its panels shown, not MSD/diffusion nor the empty curve panels ' + JSON.stringify(shown));
    const opx = await pixels(page, OBS.slice(0, 5).map((id) => 'plot-' + id));
    const nod = await page.evaluate((ids) => ids.filter((id) => !document.getElementById('plot-' + id + '-nodata').hidden), OBS.slice(0, 5));
    ok(opx.every((k) => k > 50) && !nod.length, `wall pressure, obstacle force, outflow, height, energies drew their first series (${opx.join(', ')} px)` +
      (nod.length ? '; "no data" on ' + nod.join(', ') : ''));
    const legend = (id) => page.$$eval('#plot-' + id + ' .u-legend .u-series .u-label', (ls) => ls.map((l) => l.textContent));
    const lw = await legend('walls'), lo = await legend('obstacles'), lf = await legend('outflow'), le = await legend('energies');
    ok(['x.lower', 'x.upper', 'y.lower', 'y.upper'].every((w) => lw.includes(w)) && lo.includes('obstacle 0 drag') && lo.includes('obstacle 0 lift') &&
      lf.includes('present') && lf.includes('out x.upper') && ['E_kin', 'E_pot', 'E_rot', 'sum'].every((e) => le.includes(e)),
      'legends name the walls, the obstacle and the open wall: ' + [lw, lo, lf, le].map((l) => l.slice(1).join('/')).join('; '));
    // The numbers shown are the records': particles present and the hit counts of the last record.
    const infos = await page.evaluate(() => ['walls', 'obstacles', 'outflow'].map((id) => document.getElementById('plot-' + id + '-info').textContent));
    ok(lastRec.particles_present < 800 && lastRec.outflow['x.upper'] === 800 - lastRec.particles_present &&
      infos[2].startsWith(lastRec.particles_present + ' particles present') && infos[1].startsWith(lastRec.obstacle_collisions + ' particle-obstacle hits') &&
      infos[0].startsWith(lastRec.wall_collisions + ' wall collisions') && infos[1].includes('flow along (1, 0)'),
      'panel notes match the last record (' + recs.length + ' records): ' + infos.map((t) => t.slice(0, 60)).join(' | '));
    // Rough: T_rot (#2a9d4a) on the temperature plot, named in its title and legend, and T_rot/T of the last record.
    const tpx = (await pixels(page, ['plot-energy'], [42, 157, 74]))[0];
    const lt = await legend('energy');
    const ratio = (lastRec.rotational_temperature / lastRec.temperature).toPrecision(3);
    ok(tpx > 50 && lt.includes('T_rot') && await page.isVisible('#trot-title') && (await page.textContent('#haff')).includes('T_rot/T = ' + ratio),
      `T_rot drawn beside T (${tpx} px, legend ${lt.slice(1).join('/')}): ${await page.textContent('#haff')}`);
    await page.screenshot({ path: shot.replace(/\.png$/, '') + '-observables.png', fullPage: true });
    // A stream between reservoir walls: the outflow panel counts what came in through each too.
    const sid = await submitScene({ method: 'ed', dimensions: 2,
      particles: { count: 200, box: [40, 20], initial: { positions: 'random', velocity: [0.5, 0] } },
      boundaries: { x: { type: 'walls', lower: { type: 'reservoir', volume_fraction: 0.2, velocity: [0.5, 0], temperature: 1 },
        upper: { type: 'reservoir', volume_fraction: 0.2, velocity: [0.5, 0], temperature: 1 } } },
      run: { seed: 4, until: { time: 20 } }, output: { every: { time: 2 }, observables: ['temperature', 'outflow'] } }, wid);
    const srecs = (await page.evaluate(async (i) => (await (await fetch('/api/v1/jobs/' + i + '/progress')).json()), sid))
      .records.filter((r) => r.type === 'progress');
    const slr = srecs[srecs.length - 1], sin = Object.values(slr.inflow || {}).reduce((a, x) => a + x, 0);
    await page.waitForFunction((c) => document.getElementById('plot-outflow-info').textContent.startsWith(c + ' particles present'),
      String(slr.particles_present), { timeout: 10000 }).catch(() => {});
    const sinfo = await page.textContent('#plot-outflow-info'), slf = await legend('outflow');
    ok(sin > 0 && slf.includes('in x.lower') && slf.includes('out x.upper') && sinfo.includes(sin + ' came in through reservoir walls'),
      `job ${sid} between reservoir walls: inflow drawn (${slf.slice(1).join('/')}): ${sinfo}`);

    // "no data" on a plot whose observable the scene did not ask for; the plot that has data does not say it.
    // A periodic scene: no wall, obstacle, outflow or gravity panel, no T_rot; MSD and D(t) for mean_square_displacement.
    await page.evaluate(() => { location.hash = '#/'; });
    await page.waitForFunction(() => !document.getElementById('list-view').hidden, null, { timeout: 10000 });
    await page.fill('#scene', JSON.stringify({ method: 'ed', dimensions: 2, particles: { count: 400, volume_fraction: 0.2 },
      collisions: { restitution: 0.9 }, run: { seed: 3, until: { time: 0.5 } },
      output: { every: { time: 0.05 }, observables: ['kinetic_energy', 'temperature', 'mean_square_displacement'] } }));
    await page.click('#submit-form button[type=submit]');
    await page.waitForFunction((i) => (document.getElementById('submit-msg').textContent.match(/^job (\d+)/) || [])[1] > i, wid,
      { timeout: 10000 });
    const nid = Number((await page.textContent('#submit-msg')).match(/^job (\d+)/)[1]);
    await page.evaluate((i) => { location.hash = '#/job/' + i; }, nid);
    await page.waitForFunction(() => document.getElementById('job-state').textContent === 'succeeded', null, { timeout: 60000 });
    // The last records arrive after the final state: wait for T(t) to have them (and the others to say so).
    await page.waitForFunction(() => document.getElementById('plot-energy-nodata').hidden &&
      !document.getElementById('plot-rate-nodata').hidden, null, { timeout: 10000 }).catch(() => {});
    const nodata = await page.evaluate(() => ['plot-energy', 'plot-rate', 'plot-cluster'].map((p) => {
      const n = document.getElementById(p + '-nodata');
      return !n.hidden && n.getBoundingClientRect().height > 0 && n.textContent === 'no data';
    }));
    ok(!nodata[0] && nodata[1] && nodata[2], 'job ' + nid + ' without collision_rate and clusters: "no data" on those plots, not on T(t) ' +
      JSON.stringify(nodata));
    await page.waitForFunction(() => document.getElementById('plot-diffusion-info').textContent.startsWith('last:'), null, { timeout: 10000 }).catch(() => {});
    const pshown = await page.evaluate((ids) => ids.map((id) => !document.getElementById('panel-' + id).hidden), OBS);
    const mpx = await pixels(page, ['plot-msd', 'plot-diffusion']);
    ok(JSON.stringify(pshown) === JSON.stringify([false, false, false, false, false, true, true]) && await page.isHidden('#trot-title') &&
      !(await legend('energy')).includes('T_rot') && mpx.every((k) => k > 50),
      'periodic job ' + nid + ': no wall, obstacle, outflow, gravity panel nor T_rot; MSD and D(t) drawn (' + mpx.join(', ') + ' px) ' + JSON.stringify(pshown) +
      ' ' + await page.textContent('#job-msg') + ' ' + await page.textContent('#plot-diffusion-info'));

    // Advice and an error describe the form as it was: editing it takes them away.
    await page.evaluate(() => { location.hash = '#/'; });
    await page.waitForFunction(() => !document.getElementById('list-view').hidden, null, { timeout: 10000 });
    await page.selectOption('#preset', 'cooling-2d');
    await page.click('#advise');
    await page.waitForFunction(() => !document.getElementById('advice').hidden, null, { timeout: 10000 });
    await page.type('#scene', ' ');
    ok(await page.isHidden('#advice'), 'editing the scene hides the advice given for the previous one');
    await page.fill('#scene', '{"method": ');
    await page.click('#submit-form button[type=submit]');
    const bad = await page.textContent('#submit-msg');
    await page.type('#scene', '"ed"');
    ok(/^scene: /.test(bad) && (await page.textContent('#submit-msg')) === '', 'an error about the scene goes when the scene is edited: ' + bad);

    // Cancelling asks first: dismissed, the job runs on; accepted, it is cancelled.
    // Its walls: until its first interval ends (in 1e7 time units) the only record, at time 0, has no wall pressure.
    await page.fill('#scene', JSON.stringify({ method: 'ed', dimensions: 2, particles: { count: 400, volume_fraction: 0.2 },
      boundaries: { y: { type: 'walls', lower: { type: 'specular' }, upper: { type: 'specular' } } },
      run: { seed: 1, until: { time: 1e9 } }, output: { every: { time: 1e7 }, observables: ['temperature', 'wall_force'] } }));   // rare records: the daemon keeps up
    await page.click('#submit-form button[type=submit]');
    await page.waitForFunction((i) => (document.getElementById('submit-msg').textContent.match(/^job (\d+)/) || [])[1] > i, nid,
      { timeout: 10000 });
    const cid = Number((await page.textContent('#submit-msg')).match(/^job (\d+)/)[1]);
    await page.evaluate((i) => { location.hash = '#/job/' + i; }, cid);
    await page.waitForFunction(() => !document.getElementById('panel-walls').hidden && !document.getElementById('plot-walls-nodata').hidden &&
      document.getElementById('job-state').textContent === 'running' && document.getElementById('plot-energy-nodata').hidden, null, { timeout: 15000 })
      .catch(() => {});
    const wnd = await page.evaluate(() => ({ walls: !document.getElementById('panel-walls').hidden, nodata: document.getElementById('plot-walls-nodata').textContent,
      shown: !document.getElementById('plot-walls-nodata').hidden, T: document.getElementById('plot-energy-nodata').hidden,
      legend: [...document.querySelectorAll('#plot-walls .u-legend .u-label')].map((l) => l.textContent).slice(1) }));
    ok(wnd.walls && wnd.shown && wnd.nodata === 'no data' && wnd.T && wnd.legend.join() === 'y.lower,y.upper',
      'running job ' + cid + ' with walls, its first record only: "no data" on the wall pressure (legend y.lower, y.upper), not on T(t) ' + JSON.stringify(wnd));
    await page.evaluate(() => { location.hash = '#/'; });
    await page.waitForFunction(() => !document.getElementById('list-view').hidden, null, { timeout: 10000 });
    const button = '#jobs tbody tr[data-id="' + cid + '"] button';
    await page.waitForSelector(button, { timeout: 10000 });
    const asked = [];
    page.once('dialog', (d) => { asked.push(d.type() + ': ' + d.message()); d.dismiss(); });
    await page.click(button);
    await page.waitForTimeout(1000);
    const kept = await page.evaluate(async (i) => (await (await fetch('/api/v1/jobs/' + i)).json()), cid);
    ok(asked.length === 1 && asked[0].startsWith('confirm: ') && asked[0].includes('job ' + cid) &&
      !kept.cancel_requested && !['cancelled'].includes(kept.state),
      'cancel asks first (' + (asked[0] || 'no dialog') + '); dismissed, job ' + cid + ' stays ' + kept.state);
    page.once('dialog', (d) => { asked.push(d.message()); d.accept(); });
    await page.click(button);
    await page.waitForFunction((i) => /cancelled/.test((document.querySelector('#jobs tbody tr[data-id="' + i + '"]') || {}).textContent || ''),
      cid, { timeout: 30000 });
    ok(asked.length === 2, 'accepted, job ' + cid + ' is cancelled');
    ok(errors.length === 0, 'no script errors' + (errors.length ? ': ' + errors.join('; ') : ''));
  } catch (e) {
    ok(false, 'browser session: ' + e.message.split('\n')[0]);
  } finally {
    await browser.close();
  }
  console.log(`1..${n}`);
  process.exit(failed ? 1 : 0);
})();
