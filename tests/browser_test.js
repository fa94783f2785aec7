// Dashboard in a real browser: headless Chromium (playwright-core) against a live granulard; submits a preset,
// follows the job to the end, checks the plots received data, saves a screenshot; asks for advice on the preset
// (the candidates table) and shows an auto job's advice panel; the job page's files and attempts, "no data" on
// an empty plot, nothing stale kept (advice, errors, another job's page), and a confirmation before cancelling. With a 4th argument "read-auth-token" (a daemon run
// with --read-auth token): the page asks for the token, then lists jobs and follows the event stream with it.
'use strict';
const { chromium } = require('playwright-core');
const [url, token, shot, mode] = process.argv.slice(2);
let n = 0, failed = 0;
const ok = (c, d) => { n++; if (!c) failed++; console.log(`${c ? '' : 'not '}ok ${n} - ${d}`); };
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
        .concat(['velocity_distribution', 'pair_correlation', 'structure_factor', 'clusters', 'impact_parameter'])
        .filter((o, k, a) => a.indexOf(o) === k);
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

    // "no data" on a plot whose observable the scene did not ask for; the plot that has data does not say it.
    await page.evaluate(() => { location.hash = '#/'; });
    await page.waitForFunction(() => !document.getElementById('list-view').hidden, null, { timeout: 10000 });
    await page.fill('#scene', JSON.stringify({ method: 'ed', dimensions: 2, particles: { count: 400, volume_fraction: 0.2 },
      collisions: { restitution: 0.9 }, run: { seed: 3, until: { time: 0.5 } },
      output: { every: { time: 0.05 }, observables: ['kinetic_energy', 'temperature'] } }));
    await page.click('#submit-form button[type=submit]');
    await page.waitForFunction((i) => (document.getElementById('submit-msg').textContent.match(/^job (\d+)/) || [])[1] > i, aid,
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
    await page.fill('#scene', JSON.stringify({ method: 'ed', dimensions: 2, particles: { count: 400, volume_fraction: 0.2 },
      run: { seed: 1, until: { time: 1e9 } }, output: { every: { time: 1e7 } } }));   // rare records: the daemon keeps up
    await page.click('#submit-form button[type=submit]');
    await page.waitForFunction((i) => (document.getElementById('submit-msg').textContent.match(/^job (\d+)/) || [])[1] > i, nid,
      { timeout: 10000 });
    const cid = Number((await page.textContent('#submit-msg')).match(/^job (\d+)/)[1]);
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
