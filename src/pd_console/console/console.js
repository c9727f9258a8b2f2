// The pd console page: frames over a WebSocket, drawn with a small canvas plotter; login and
// controls through the console's JSON API. No library, nothing loaded from the internet.
'use strict';

const COLORS = ['#2563eb', '#dc2626', '#16a34a', '#9333ea', '#ea580c', '#0891b2'];
const state = { frame: null, authenticated: false, controls: true, frames: 0 };
const $ = (id) => document.getElementById(id);

// ---- plotting -----------------------------------------------------------------------------
function niceStep(span, count) {
  const raw = span / Math.max(1, count);
  const power = Math.pow(10, Math.floor(Math.log10(raw)));
  const unit = raw / power;
  return (unit < 1.5 ? 1 : unit < 3 ? 2 : unit < 7 ? 5 : 10) * power;
}

function extent(arrays) {
  let lo = Infinity, hi = -Infinity;
  for (const values of arrays) {
    for (const v of values) {
      if (v === null || !isFinite(v)) continue;
      if (v < lo) lo = v;
      if (v > hi) hi = v;
    }
  }
  if (lo === Infinity) return [0, 1];
  if (lo === hi) { const pad = Math.abs(lo) * 0.1 || 1; return [lo - pad, hi + pad]; }
  const pad = (hi - lo) * 0.05;
  return [lo - pad, hi + pad];
}

function formatTick(v, step) {
  const digits = Math.max(0, -Math.floor(Math.log10(step)));
  return v.toFixed(Math.min(digits, 6));
}

// series: [{x: [...], y: [...], color, label}]
function drawPlot(canvas, series, options) {
  const ratio = window.devicePixelRatio || 1;
  const width = canvas.clientWidth, height = canvas.clientHeight;
  if (canvas.width !== Math.round(width * ratio)) canvas.width = Math.round(width * ratio);
  if (canvas.height !== Math.round(height * ratio)) canvas.height = Math.round(height * ratio);
  const ctx = canvas.getContext('2d');
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  ctx.clearRect(0, 0, width, height);
  const left = 58, right = 10, top = 20, bottom = 32;
  const plotW = width - left - right, plotH = height - top - bottom;
  const [x0, x1] = extent(series.map((s) => s.x));
  const [y0, y1] = extent(series.map((s) => s.y));
  const px = (x) => left + (x - x0) / (x1 - x0) * plotW;
  const py = (y) => top + plotH - (y - y0) / (y1 - y0) * plotH;
  ctx.font = '11px system-ui, sans-serif';
  ctx.strokeStyle = '#e5e7eb'; ctx.fillStyle = '#4b5563'; ctx.lineWidth = 1;
  const xs = niceStep(x1 - x0, 6), ys = niceStep(y1 - y0, 5);
  ctx.textAlign = 'center'; ctx.textBaseline = 'top';
  for (let v = Math.ceil(x0 / xs) * xs; v <= x1; v += xs) {
    ctx.beginPath(); ctx.moveTo(px(v), top); ctx.lineTo(px(v), top + plotH); ctx.stroke();
    ctx.fillText(formatTick(v, xs), px(v), top + plotH + 3);
  }
  ctx.textAlign = 'right'; ctx.textBaseline = 'middle';
  for (let v = Math.ceil(y0 / ys) * ys; v <= y1; v += ys) {
    ctx.beginPath(); ctx.moveTo(left, py(v)); ctx.lineTo(left + plotW, py(v)); ctx.stroke();
    ctx.fillText(formatTick(v, ys), left - 4, py(v));
  }
  ctx.strokeStyle = '#9ca3af'; ctx.strokeRect(left, top, plotW, plotH);
  ctx.textAlign = 'center'; ctx.textBaseline = 'bottom'; ctx.fillStyle = '#111827';
  ctx.fillText(options.xlabel || '', left + plotW / 2, height - 1);
  ctx.textAlign = 'left'; ctx.textBaseline = 'top';
  ctx.fillText(options.title || '', left, 3);
  let drawn = 0, legendX = left + plotW;
  ctx.textAlign = 'right';
  series.forEach((s, i) => {
    const color = s.color || COLORS[i % COLORS.length];
    ctx.strokeStyle = color; ctx.lineWidth = 1.4; ctx.beginPath();
    let pen = false;
    for (let k = 0; k < s.x.length; k++) {
      const x = s.x[k], y = s.y[k];
      if (x === null || y === null) { pen = false; continue; }
      if (pen) ctx.lineTo(px(x), py(y)); else ctx.moveTo(px(x), py(y));
      pen = true; drawn++;
    }
    ctx.stroke();
    if (s.label) {
      ctx.fillStyle = color; ctx.fillText(s.label, legendX, 3);
      legendX -= ctx.measureText(s.label).width + 12;
    }
  });
  canvas.dataset.points = String(drawn);
}

// ---- the page ------------------------------------------------------------------------------
const scale = (values, factor) => values.map((v) => (v === null ? null : v * factor));

function fmtSeconds(s) {
  if (s === null || s === undefined) return '–';
  if (s < 120) return s.toFixed(1) + ' s';
  if (s < 7200) return (s / 60).toFixed(1) + ' min';
  return (s / 3600).toFixed(2) + ' h';
}

function siteKey(site) { return site.name || 'default'; }

function ensureSite(site) {
  const key = siteKey(site);
  let card = document.querySelector(`[data-site="${key}"]`);
  if (card) return card;
  card = document.createElement('section');
  card.className = 'card site';
  card.dataset.site = key;
  card.innerHTML = `
    <h2>Site <span class="site-name"></span> <span class="muted site-label"></span></h2>
    <div class="row">
      <div><span class="label">bridge</span> <span class="badge bridge-state">–</span></div>
      <div class="counts muted"></div>
      <button class="btn-reset" data-command="reset">Reset bridge</button>
      <button class="btn-reset-estop" data-command="reset_emergency_stop">Reset e-stop</button>
    </div>
    <div class="muted bridge-message"></div>
    <h3>Bridge limits</h3>
    <div class="gauges"></div>
    <div class="dofs"></div>`;
  card.querySelector('.site-name').textContent = site.name || '(default)';
  for (const button of card.querySelectorAll('button')) {
    button.addEventListener('click', () => askControl(button.dataset.command, site.name));
  }
  $('sites').appendChild(card);
  return card;
}

function ensureDof(card, dof) {
  let box = card.querySelector(`[data-dof="${dof.name}"]`);
  if (box) return box;
  box = document.createElement('div');
  box.dataset.dof = dof.name;
  box.innerHTML = `<h3>DOF ${dof.name}</h3><div class="plots">
      <canvas class="plot displacement"></canvas><canvas class="plot force"></canvas>
      <canvas class="plot hysteresis"></canvas><canvas class="plot tracking"></canvas></div>`;
  card.querySelector('.dofs').appendChild(box);
  return box;
}

function renderGauges(card, gauges) {
  const holder = card.querySelector('.gauges');
  holder.innerHTML = '';
  for (const g of gauges) {
    const div = document.createElement('div');
    div.className = 'gauge';
    div.dataset.limit = g.name;
    if (g.off) {
      div.innerHTML = `<div class="text">${g.name}: off</div>`;
    } else {
      const ratio = Math.min(1, g.ratio || 0), peak = Math.min(1, g.peak_ratio || 0);
      if (peak > 0.9) div.classList.add('alarm'); else if (peak > 0.7) div.classList.add('warn');
      div.innerHTML = `<div class="text">${g.name}: ${(100 * (g.ratio || 0)).toFixed(1)} %
        (peak ${(100 * (g.peak_ratio || 0)).toFixed(1)} %) of ${g.limit} ${g.unit}</div>
        <div class="bar"><div class="fill" style="width:${100 * ratio}%"></div>
        <div class="peak" style="left:${100 * peak}%"></div></div>`;
    }
    holder.appendChild(div);
  }
}

function renderSite(site) {
  const card = ensureSite(site);
  card.querySelector('.site-label').textContent = site.label ? `(${site.label})` : '';
  const bridge = site.bridge;
  const badge = card.querySelector('.bridge-state');
  badge.textContent = bridge ? bridge.state_name : 'no bridge status';
  badge.className = 'badge bridge-state ' + (bridge ? bridge.state_name : '');
  const c = site.counts;
  let counts = `commands ${c.commands} · re-sends ${c.resends} · feedback ok ${c.ok}` +
    ` · limit ${c.limit} · fault ${c.fault}`;
  if (bridge) counts += ` · refused ${bridge.refused}` +
    (bridge.refused_by_reason ? ` (${bridge.refused_by_reason})` : '');
  card.querySelector('.counts').textContent = counts;
  card.querySelector('.bridge-message').textContent =
    (bridge && bridge.message) || site.message || '';
  renderGauges(card, site.gauges);
  site.dofs.forEach((dof) => {
    const box = ensureDof(card, dof);
    drawPlot(box.querySelector('.displacement'), [
      { x: dof.t, y: scale(dof.command, 1000), label: 'command' },
      { x: dof.t, y: scale(dof.measured, 1000), label: 'measured' }],
      { title: 'displacement [mm]', xlabel: 'time [s]' });
    drawPlot(box.querySelector('.force'), [
      { x: dof.t, y: scale(dof.force, 0.001), label: 'restoring force' }],
      { title: 'restoring force [kN]', xlabel: 'time [s]' });
    drawPlot(box.querySelector('.hysteresis'), [
      { x: scale(dof.measured, 1000), y: scale(dof.force, 0.001), color: '#9333ea' }],
      { title: 'hysteresis: force [kN] vs displacement', xlabel: 'measured displacement [mm]' });
    drawPlot(box.querySelector('.tracking'), [
      { x: dof.t, y: scale(dof.error, 1000), label: 'error [mm]' },
      { x: dof.t, y: scale(dof.indicator, 1e6), label: 'TI [mm²]', color: '#ea580c' }],
      { title: 'tracking: measured − command, indicator', xlabel: 'time [s]' });
  });
}

function render(frame) {
  state.frame = frame;
  state.frames += 1;
  document.body.dataset.frames = String(state.frames);
  document.body.dataset.mode = frame.mode;
  const t = frame.test;
  $('source').textContent = frame.mode === 'run' ? `finished run: ${frame.source}` : 'live';
  $('test-id').textContent = t.id || '–';
  $('state').textContent = t.state_name;
  $('state').className = 'badge ' + t.state_name;
  const step = Math.min(t.total, Math.max(t.step, t.live_step || 0));
  $('step').textContent = `${step} / ${t.total}`;
  $('rate').textContent = t.rate ? `${t.rate.toFixed(1)} steps/s` : '–';
  $('eta').textContent = fmtSeconds(t.eta);
  $('retries').textContent = t.retries;
  $('ignored').textContent = t.ignored;
  $('refused').textContent = t.refused + (t.refused_by_reason ? ` (${t.refused_by_reason})` : '');
  $('message').textContent = t.message || '';
  $('progress-bar').style.width = t.total ? `${100 * step / t.total}%` : '0';
  frame.sites.forEach(renderSite);
  if (frame.energy) {
    $('energy').classList.remove('hidden');
    drawPlot($('plot-energy'), [{ x: frame.energy.t, y: frame.energy.error, label: 'E_error [J]' }],
      { title: 'energy error [J]', xlabel: 'time [s]' });
  }
  if (frame.figures && frame.figures.length && !$('figure-list').childElementCount) {
    $('figures').classList.remove('hidden');
    for (const name of frame.figures) {
      const img = document.createElement('img');
      img.src = `/figures/${encodeURIComponent(name)}`; img.alt = name; img.title = name;
      $('figure-list').appendChild(img);
    }
  }
  updateButtons();
}

function updateButtons() {
  const live = !state.frame || state.frame.mode === 'live';
  document.querySelectorAll('[data-command]').forEach((b) => {
    b.disabled = !state.authenticated || !live;
  });
  $('estop').disabled = !live;
  $('login-box').classList.toggle('hidden', state.authenticated || !live);
  $('auth-state').textContent = !live ? 'a finished run: nothing to steer'
    : state.authenticated ? 'logged in: you may steer the test' : 'watching only (not logged in)';
}

// ---- server calls --------------------------------------------------------------------------
async function post(path, body) {
  const response = await fetch(path, {
    method: 'POST', credentials: 'same-origin',
    headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body || {}),
  });
  let data = {};
  try { data = await response.json(); } catch (e) { data = {}; }
  return { status: response.status, data };
}

function say(text) { $('last-result').textContent = text; }

async function login(token) {
  const { status, data } = await post('/api/login', { token });
  state.authenticated = status === 200;
  say(state.authenticated ? 'logged in' : `login refused (${status}): ${data.error || ''}`);
  updateButtons();
}

async function sendControl(command, site) {
  const body = { command, reason: 'from the console page' };
  if (site !== undefined) body.site = site;
  const { status, data } = await post('/api/control', body);
  say(status === 200 ? `${command} sent on ${data.topic}` : `${command} refused (${status}): ${data.error || ''}`);
  document.body.dataset.lastStatus = String(status);
}

function confirmThen(text, action) {
  const dialog = $('confirm');
  $('confirm-text').textContent = text;
  const ok = $('confirm-ok'), cancel = $('confirm-cancel');
  const close = () => { ok.onclick = null; cancel.onclick = null; dialog.close(); };
  ok.onclick = () => { close(); action(); };
  cancel.onclick = () => { close(); say('cancelled'); };
  dialog.showModal();
}

function askControl(command, site) {
  const where = site === undefined ? 'the test' : `the bridge of site ${site || '(default)'}`;
  confirmThen(`Send "${command}" to ${where}?`, () => sendControl(command, site));
}

// ---- start ---------------------------------------------------------------------------------
function connect() {
  const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
  const socket = new WebSocket(`${scheme}://${location.host}/ws`);
  socket.onmessage = (event) => render(JSON.parse(event.data));
  socket.onclose = () => setTimeout(connect, 1000);
}

async function start() {
  $('login-button').addEventListener('click', () => login($('login-token').value.trim()));
  $('login-token').addEventListener('keydown', (e) => { if (e.key === 'Enter') login(e.target.value.trim()); });
  for (const id of ['btn-pause', 'btn-resume', 'btn-abort']) {
    $(id).addEventListener('click', () => askControl($(id).dataset.command));
  }
  $('estop').addEventListener('click', async () => {
    const { status, data } = await post('/api/estop', { reason: 'console page emergency stop' });
    say(status === 200 ? `EMERGENCY STOP sent on ${data.topic}` : `emergency stop failed (${status})`);
  });
  try {
    const session = await (await fetch('/api/session', { credentials: 'same-origin' })).json();
    state.authenticated = session.authenticated;
  } catch (e) { /* the server is starting */ }
  const match = location.hash.match(/token=([^&]+)/);
  if (match) {
    history.replaceState(null, '', location.pathname);
    if (!state.authenticated) await login(decodeURIComponent(match[1]));
  }
  updateButtons();
  connect();
}

start();
