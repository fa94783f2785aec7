// Dashboard in a real browser: headless Chromium (playwright-core) against a live granulard; submits a preset,
// follows the job to the end, checks the plots received data, saves a screenshot; asks for advice on the preset
// (the candidates table) and shows an auto job's advice panel.
'use strict';
const { chromium } = require('playwright-core');
const [url, token, shot] = process.argv.slice(2);
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
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('response', (r) => { if (r.status() >= 400) errors.push(r.status() + ' ' + r.url()); });
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
        .concat(['velocity_distribution', 'pair_correlation', 'structure_factor']);
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
    const cpx = await page.evaluate(() => ['plot-vdist', 'plot-gofr', 'plot-sofk'].map((id) => {
      const c = document.querySelector('#' + id + ' canvas');
      if (!c) return 0;
      const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let k = 0;
      for (let i = 0; i < d.length; i += 4) if (Math.abs(d[i] - 47) < 30 && Math.abs(d[i + 1] - 111) < 30 && Math.abs(d[i + 2] - 222) < 30 && d[i + 3] > 100) k++;
      return k;
    }));
    ok(cpx.every((k) => k > 50), `P(c), g(r), S(k) plots drew the last sample (${cpx.join(', ')} px): ${await page.textContent('#curves-info')}`);
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
    ok(errors.length === 0, 'no script errors' + (errors.length ? ': ' + errors.join('; ') : ''));
  } catch (e) {
    ok(false, 'browser session: ' + e.message.split('\n')[0]);
  } finally {
    await browser.close();
  }
  console.log(`1..${n}`);
  process.exit(failed ? 1 : 0);
})();
