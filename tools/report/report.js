// The report page's script (vigil report): draws a finished run from the data `vigil report`
// inlined. No network: the map is an inlined PNG, the videos are files beside the page.
(function () {
  'use strict';
  const D = JSON.parse(document.getElementById('vigil-data').textContent);
  const M = D.map;
  const duration = D.duration || (D.ticks.length ? D.ticks[D.ticks.length - 1][0] : 0);
  const $ = (id) => document.getElementById(id);
  const fmt = (v, d) => (v === undefined || v === null || Number.isNaN(v)) ? '–' : (typeof v === 'number' ? v.toFixed(d === undefined ? 2 : d) : String(v));
  const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c]));
  // Map frame (metres) to canvas pixels: the same transform `vigil run` draws its top-down view with.
  const px = (x, y) => [(x - M.origin_x) * M.scale, (M.height_m - (y - M.origin_y)) * M.scale];
  const MODE_COLOURS = { avoiding: '#ff8c00', waiting: '#dc0000', recovering: '#dc0000', failed: '#dc0000', localizing: '#a03cb4' };
  const modeColour = (m) => MODE_COLOURS[m] || '#3caa3c';
  const CLASS_COLOURS = { person: '#8a2be2', bag: '#e07000' };

  // ---- Summary ----
  const S = D.summary || {};
  $('title').textContent = S.scenario || '';
  const sumRows = [['scenario file', S.scenario_file], ['seed', S.seed], ['simulated', fmt(S.sim_seconds, 1) + ' s'],
    ['wall', fmt(S.wall_seconds, 1) + ' s'], ['real-time factor', fmt(S.real_time_factor, 2)], ['steps', S.steps],
    ['ground truth SHA-256', S.ground_truth_sha256], ['robots / people / objects / cameras', [S.robots, S.people, S.objects, S.cameras].join(' / ')],
    ['ground-truth events', S.events], ['map', M.file]];
  $('summary').innerHTML = sumRows.map((r) => '<tr><td>' + esc(r[0]) + '</td><td class="l"><code>' + esc(r[1] === undefined ? '–' : r[1]) + '</code></td></tr>').join('');

  // ---- Indexes over time ----
  const tickTimes = D.ticks.map((k) => k[0]);
  // The last index i with times[i] <= t (-1 before the first).
  function lastAtOrBefore(times, t) {
    let lo = 0, hi = times.length - 1, ans = -1;
    while (lo <= hi) {
      const mid = (lo + hi) >> 1;
      if (times[mid] <= t + 1e-6) { ans = mid; lo = mid + 1; } else hi = mid - 1;
    }
    return ans;
  }
  // Reports per robot: [t, robot, x, y, yaw, mode, role, gx, gy, event, localized].
  const reports = {};
  for (const r of D.robots) (reports[r[1]] = reports[r[1]] || []).push(r);
  const reportTimes = {};
  for (const id in reports) reportTimes[id] = reports[id].map((r) => r[0]);
  const reportAt = (id, t) => { const i = reports[id] ? lastAtOrBefore(reportTimes[id], t) : -1; return i >= 0 ? reports[id][i] : null; };
  // Trails: per entity, [t, x, y] from the ticks.
  const trails = {};
  for (const [t, ents] of D.ticks) for (const e of ents) (trails[e[0]] = trails[e[0]] || []).push([t, e[1], e[2]]);
  // Tracks per camera, grouped by stamp.
  const trackStamps = {};
  for (const tr of D.tracks) {
    const cam = trackStamps[tr[1]] = trackStamps[tr[1]] || { times: [], rows: [] };
    if (!cam.times.length || cam.times[cam.times.length - 1] !== tr[0]) { cam.times.push(tr[0]); cam.rows.push([]); }
    cam.rows[cam.rows.length - 1].push(tr);
  }

  // ---- Top-down view ----
  const canvas = $('topdown');
  canvas.width = M.width;
  canvas.height = M.height;
  const ctx = canvas.getContext('2d');
  const mapImg = $('map');
  const lw = Math.max(1, M.scale / 20);
  $('legend').innerHTML = [['#28a028', 'robot (true pose)'], ['transparent;border:2px solid #0050dc', 'believed pose'],
    ['#3caa3c', 'trail: driving'], ['#ff8c00', 'avoiding'], ['#dc0000', 'waiting / recovering'], ['#a03cb4', 'localising'],
    ['#c800c8', 'goal'], ['#00a0c8', 'planned path'], ['#8a2be2', 'person track'], ['#e07000', 'bag track'], ['transparent;border:2px solid #dc0000', 'event (truth)'],
    ['transparent;border:2px solid #0050dc', 'event (reported)']]
    .map((l) => '<span><i style="background:' + l[0] + '"></i>' + esc(l[1]) + '</span>').join('');

  function label(text, x, y, colour) {
    ctx.font = Math.round(10 + 2 * lw) + 'px sans-serif';
    ctx.fillStyle = colour;
    ctx.fillText(text, x, y);
  }

  // Draws the run's state at the last ground-truth state at or before `at`: everything in the
  // view (bodies, beliefs, goals, tracks, events) is of that one time.
  function drawAt(at) {
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(mapImg, 0, 0);
    const ti = lastAtOrBefore(tickTimes, at);
    const ents = ti >= 0 ? D.ticks[ti][1] : [];
    const shown = ti >= 0 ? D.ticks[ti][0] : 0;
    const t = shown;
    // Robots' trails, coloured by the mode their controller reported.
    ctx.lineWidth = Math.max(2, lw);
    for (const id in trails) {
      const info = D.entities[id];
      if (!info || info.kind !== 'robot') continue;
      const tr = trails[id];
      for (let k = 1; k < tr.length && tr[k][0] <= shown + 1e-6; ++k) {
        const rep = reportAt(id, tr[k][0]);
        ctx.strokeStyle = modeColour(rep ? rep[5] : '');
        ctx.beginPath();
        ctx.moveTo(...px(tr[k - 1][1], tr[k - 1][2]));
        ctx.lineTo(...px(tr[k][1], tr[k][2]));
        ctx.stroke();
      }
    }
    // People's trails over the last 20 s.
    ctx.lineWidth = Math.max(1, lw);
    for (const id in trails) {
      const info = D.entities[id];
      if (!info || info.kind !== 'person') continue;
      ctx.strokeStyle = info.colour + '80';
      ctx.beginPath();
      let first = true;
      for (const p of trails[id]) {
        if (p[0] > shown + 1e-6) break;
        if (p[0] < shown - 20) continue;
        const [x, y] = px(p[1], p[2]);
        if (first) ctx.moveTo(x, y); else ctx.lineTo(x, y);
        first = false;
      }
      ctx.stroke();
    }
    // Events so far: truth (red ring), reported by the video server (blue diamond).
    ctx.lineWidth = Math.max(2, lw);
    for (const e of D.truth_events) {
      if (e.t > t + 1e-6) continue;
      const [x, y] = px(e.x, e.y);
      ctx.strokeStyle = '#dc0000';
      ctx.beginPath();
      ctx.arc(x, y, 0.7 * M.scale, 0, 2 * Math.PI);
      ctx.stroke();
      label(e.kind, x + 0.75 * M.scale, y - 0.5 * M.scale, '#dc0000');
    }
    for (const e of D.events) {
      if (e.t > t + 1e-6 || e.x === undefined || e.cancelled) continue;
      const [x, y] = px(e.x, e.y);
      const r = 0.55 * M.scale;
      ctx.strokeStyle = '#0050dc';
      ctx.beginPath();
      ctx.moveTo(x, y - r); ctx.lineTo(x + r, y); ctx.lineTo(x, y + r); ctx.lineTo(x - r, y); ctx.closePath();
      ctx.stroke();
    }
    // Tracks: each camera's latest tick within half a second.
    ctx.lineWidth = Math.max(1, lw);
    for (const cam in trackStamps) {
      const cs = trackStamps[cam];
      const i = lastAtOrBefore(cs.times, t);
      if (i < 0 || t - cs.times[i] > 0.5) continue;
      for (const tr of cs.rows[i]) {
        const [x, y] = px(tr[4], tr[5]);
        const h = 0.3 * M.scale;
        ctx.strokeStyle = CLASS_COLOURS[tr[3]] || '#555';
        ctx.strokeRect(x - h, y - h, 2 * h, 2 * h);
        label(cam.replace(/^cam_/, '') + ':' + tr[2], x + h + 2, y + h + 10, ctx.strokeStyle);
      }
    }
    // Objects.
    for (const e of ents) {
      const info = D.entities[e[0]];
      if (!info || info.kind === 'robot' || info.kind === 'person') continue;
      const [x, y] = px(e[1], e[2]);
      const hx = Math.max(4, (info.size_x || 0.4) * M.scale / 2), hy = Math.max(4, (info.size_y || 0.4) * M.scale / 2);
      ctx.fillStyle = info.colour;
      ctx.fillRect(x - hx, y - hy, 2 * hx, 2 * hy);
      ctx.lineWidth = Math.max(1, lw);
      ctx.strokeStyle = info.authorised === false ? '#dc0000' : '#008c00';
      ctx.strokeRect(x - hx, y - hy, 2 * hx, 2 * hy);
      label(e[0], x + hx + 2, y + hy + 10, '#3c3c3c');
    }
    // Robots: goal and assignment, believed pose, body.
    const status = [];
    for (const e of ents) {
      const info = D.entities[e[0]];
      if (!info || info.kind !== 'robot') continue;
      const [x, y] = px(e[1], e[2]);
      const rad = Math.max(4, info.radius * M.scale);
      const rep = reportAt(e[0], t);
      if (rep) {
        const [gx, gy] = px(rep[7], rep[8]);
        if (rep[7] !== 0 || rep[8] !== 0) {
          if (rep[6] === 'respond' || rep[6] === 'guard') {
            ctx.strokeStyle = rep[6] === 'guard' ? '#c80000' : '#ff7800';
            ctx.lineWidth = Math.max(2, lw);
            ctx.beginPath(); ctx.moveTo(x, y); ctx.lineTo(gx, gy); ctx.stroke();
          }
          const s = Math.max(3, 0.25 * M.scale);
          ctx.strokeStyle = '#c800c8';
          ctx.lineWidth = Math.max(2, lw + 1);
          ctx.beginPath(); ctx.moveTo(gx - s, gy - s); ctx.lineTo(gx + s, gy + s); ctx.moveTo(gx - s, gy + s); ctx.lineTo(gx + s, gy - s); ctx.stroke();
        }
        // What is left of the planned path (teal).
        const plan = rep[11] || [];
        if (plan.length >= 2) {
          ctx.strokeStyle = '#00a0c8';
          ctx.lineWidth = Math.max(1, lw);
          ctx.beginPath();
          plan.forEach((p, k) => { const [qx, qy] = px(p[0], p[1]); if (k) ctx.lineTo(qx, qy); else ctx.moveTo(qx, qy); });
          ctx.stroke();
        }
        const [bx, by] = px(rep[2], rep[3]);
        ctx.strokeStyle = '#0050dc';
        ctx.lineWidth = Math.max(1, lw);
        ctx.beginPath(); ctx.arc(bx, by, rad + 0.1 * M.scale, 0, 2 * Math.PI); ctx.stroke();
        status.push(e[0] + ': ' + (rep[6] ? rep[6] + ' / ' : '') + rep[5] + (rep[10] ? '' : ' (not localised)'));
      }
      ctx.fillStyle = info.colour;
      ctx.beginPath(); ctx.arc(x, y, rad, 0, 2 * Math.PI); ctx.fill();
      ctx.strokeStyle = '#003c00';
      ctx.lineWidth = Math.max(2, lw + 1);
      ctx.beginPath();
      ctx.moveTo(x + 0.6 * rad * Math.cos(e[3]), y - 0.6 * rad * Math.sin(e[3]));
      ctx.lineTo(x + 1.4 * rad * Math.cos(e[3]), y - 1.4 * rad * Math.sin(e[3]));
      ctx.stroke();
      label(e[0] + (rep ? ' ' + (rep[6] ? rep[6] + '/' : '') + rep[5] : ''), x + rad + 2, y - rad, '#005a00');
    }
    // People.
    for (const e of ents) {
      const info = D.entities[e[0]];
      if (!info || info.kind !== 'person') continue;
      const [x, y] = px(e[1], e[2]);
      const rad = Math.max(4, info.radius * M.scale);
      ctx.fillStyle = info.colour;
      ctx.beginPath(); ctx.arc(x, y, rad, 0, 2 * Math.PI); ctx.fill();
      ctx.strokeStyle = '#000';
      ctx.lineWidth = 1;
      ctx.stroke();
      ctx.beginPath();
      ctx.moveTo(x + 0.5 * rad * Math.cos(e[3]), y - 0.5 * rad * Math.sin(e[3]));
      ctx.lineTo(x + 1.6 * rad * Math.cos(e[3]), y - 1.6 * rad * Math.sin(e[3]));
      ctx.stroke();
      label(e[0], x + rad + 2, y - rad, '#000');
    }
    ctx.font = '14px sans-serif';
    ctx.fillStyle = '#000';
    ctx.fillText('t = ' + t.toFixed(2) + ' s', 8, 18);
    $('status').textContent = status.join('\n');
    return shown;
  }

  // ---- Timeline ----
  const tl = $('timeline');
  tl.width = Math.max(M.width, 800);
  const tctx = tl.getContext('2d');
  const tx = (t) => 10 + (tl.width - 20) * (duration > 0 ? t / duration : 0);
  function drawTimeline(t) {
    tctx.clearRect(0, 0, tl.width, tl.height);
    tctx.font = '11px sans-serif';
    tctx.fillStyle = '#666';
    const step = duration > 300 ? 60 : duration > 60 ? 10 : duration > 10 ? 5 : 1;
    for (let s = 0; s <= duration + 1e-9; s += step) {
      tctx.fillRect(tx(s), 78, 1, 6);
      tctx.fillText(s + ' s', tx(s) + 2, 84);
    }
    const rows = [['truth', D.truth_events, '#dc0000', 12], ['reported', D.events, '#0050dc', 30], ['cameras', D.camera_events, '#7aa7ff', 46]];
    for (const [name, list, colour, y] of rows) {
      tctx.fillStyle = '#444';
      tctx.fillText(name, tl.width - 60, y + 4);
      tctx.fillStyle = colour;
      for (const e of list) {
        if (e.cancelled) continue;
        tctx.beginPath(); tctx.moveTo(tx(e.t), y - 6); tctx.lineTo(tx(e.t) + 5, y + 4); tctx.lineTo(tx(e.t) - 5, y + 4); tctx.fill();
      }
    }
    for (const r of D.robots) {
      if (!r[9]) continue;
      tctx.fillStyle = r[9] === 'goal_reached' ? '#3caa3c' : r[9] === 'goal_failed' || r[9] === 'task_rejected' ? '#dc0000' : '#999';
      tctx.fillRect(tx(r[0]) - 1, 58, 3, 8);
    }
    for (const c of D.contacts) { tctx.fillStyle = '#ff8c00'; tctx.fillRect(tx(c.t) - 1, 68, 3, 6); }
    tctx.fillStyle = '#000';
    tctx.fillRect(tx(t) - 1, 0, 2, tl.height);
  }
  tl.addEventListener('click', (ev) => {
    const r = tl.getBoundingClientRect();
    seek(Math.min(duration, Math.max(0, ((ev.clientX - r.left) * tl.width / r.width - 10) / (tl.width - 20) * duration)));
  });

  // ---- Videos ----
  const videos = [];
  const vl = $('video-list');
  const addVideo = (file, caption, rate) => {
    const fig = document.createElement('figure');
    const browserPlays = /\.mp4$/.test(file);
    fig.innerHTML = (browserPlays ? '<video muted playsinline preload="metadata" src="' + esc(file) + '"></video>'
      : '<p class="muted">' + esc(file) + ' (AVI: browsers do not play it; run with --video-format mp4)</p>') +
      '<figcaption>' + esc(caption) + (rate ? ', ' + rate + ' Hz' : '') + ' — <a href="' + esc(file) + '">' + esc(file) + '</a></figcaption>';
    vl.appendChild(fig);
    const v = fig.querySelector('video');
    if (v) videos.push(v);
  };
  for (const cam of D.cameras) for (const v of cam.videos) addVideo(v.file, cam.id + (v.what === 'camera' ? ' (left view)' : ' (' + v.what + ' tracker)'), cam.rate_hz);
  if (D.topdown_video) addVideo(D.topdown_video, 'top-down view as the simulator drew it');
  if (!vl.children.length) vl.innerHTML = '<p class="muted">No videos in this run (written with --no-video).</p>';
  function syncVideos(t, playing, speed) {
    for (const v of videos) {
      try {
        if (Number.isFinite(v.duration) && t > v.duration) { v.pause(); continue; }
        if (Math.abs(v.currentTime - t) > (playing ? 0.5 : 0.04)) v.currentTime = t;
        v.playbackRate = speed;
        if (playing && v.paused) { const p = v.play(); if (p && p.catch) p.catch(() => {}); }
        if (!playing && !v.paused) v.pause();
      } catch (e) { /* a video that cannot seek yet */ }
    }
  }

  // ---- Playback ----
  const slider = $('slider');
  slider.max = String(duration);
  let now = 0, playing = false, lastFrame = 0;
  function seek(t) {
    now = Math.min(duration, Math.max(0, t));
    slider.value = String(now);
    $('clock').textContent = 't = ' + now.toFixed(2) + ' s';
    const shown = drawAt(now);
    drawTimeline(now);
    syncVideos(now, playing, Number($('speed').value));
    const root = document.documentElement;
    const r = canvas.getBoundingClientRect();
    root.setAttribute('data-time', String(shown));
    root.setAttribute('data-canvas', [r.left + window.scrollX, r.top + window.scrollY, canvas.width, canvas.height].join(','));
    root.setAttribute('data-transform', [M.scale, M.origin_x, M.origin_y, M.height_m].join(','));
  }
  function frame(ts) {
    if (!playing) return;
    const dt = lastFrame ? (ts - lastFrame) / 1000 : 0;
    lastFrame = ts;
    seek(now + dt * Number($('speed').value));
    if (now >= duration) { setPlaying(false); return; }
    requestAnimationFrame(frame);
  }
  function setPlaying(on) {
    playing = on;
    $('play').textContent = on ? 'Pause' : 'Play';
    lastFrame = 0;
    syncVideos(now, playing, Number($('speed').value));
    if (on) requestAnimationFrame(frame);
  }
  $('play').addEventListener('click', () => { if (now >= duration) seek(0); setPlaying(!playing); });
  slider.addEventListener('input', () => seek(Number(slider.value)));
  $('speed').addEventListener('change', () => syncVideos(now, playing, Number($('speed').value)));

  // ---- Tables ----
  const E = D.eval || null;
  const table = (head, rows, leftCols) => '<table><tr>' + head.map((h, i) => '<th' + (i < (leftCols || 1) ? ' class="l"' : '') + '>' + esc(h) + '</th>').join('') + '</tr>' +
    rows.map((r) => '<tr' + (r.seek !== undefined ? ' data-seek="' + r.seek + '" style="cursor:pointer"' : '') + '>' +
      r.map((c, i) => '<td' + (i < (leftCols || 1) ? ' class="l"' : '') + '>' + c + '</td>').join('') + '</tr>').join('') + '</table>';
  // Truth against reported: each truth event with the first reported one of its kind within the
  // matching window (eval.json's, else vigil eval's defaults), one reported event per truth event.
  const match = (E && E.events && E.events.match) || { early_s: 1, max_latency_s: 10, max_distance_m: 1.5 };
  const used = new Set();
  const eventRows = [];
  // As vigil eval matches: truth events in order of confirmation, each to the unused report of
  // its kind nearest in time within the window and distance.
  const truthOrder = D.truth_events.slice().sort((a, b) => (a.confirmed === undefined ? a.t : a.confirmed) - (b.confirmed === undefined ? b.t : b.confirmed));
  for (const te of truthOrder) {
    let best = -1, bestDt = Infinity;
    const from = te.confirmed === undefined ? te.t : te.confirmed;
    D.events.forEach((re, i) => {
      if (used.has(i) || re.kind !== te.kind || re.cancelled) return;
      if (re.t < from - match.early_s || re.t > from + match.max_latency_s) return;
      if (re.x !== undefined && Math.hypot(re.x - te.x, re.y - te.y) > match.max_distance_m) return;
      if (Math.abs(re.t - from) < bestDt) { bestDt = Math.abs(re.t - from); best = i; }
    });
    const confirmed = te.confirmed === undefined ? te.t : te.confirmed;
    const row = [esc(te.kind), fmt(te.t) + (confirmed !== te.t ? ' (' + fmt(confirmed) + ')' : ''), best >= 0 ? fmt(D.events[best].t) : '<span class="bad">missed</span>',
      best >= 0 ? fmt(D.events[best].t - confirmed) : '–', best >= 0 && D.events[best].x !== undefined ? fmt(Math.hypot(D.events[best].x - te.x, D.events[best].y - te.y)) : '–',
      best >= 0 ? esc(D.events[best].camera) : '–', esc((te.people || []).join(', ')), esc(te.object || '')];
    row.seek = te.t;
    if (best >= 0) used.add(best);
    eventRows.push(row);
  }
  D.events.forEach((re, i) => {
    if (used.has(i) || re.cancelled) return;
    const row = [esc(re.kind), '<span class="bad">none</span>', fmt(re.t), '–', '–', esc(re.camera), '', ''];
    row.seek = re.t;
    eventRows.push(row);
  });
  let eventsHtml = '<p>Truth times are when it happened (in brackets: when it is confirmed, which latency counts from).</p>' + table(['kind', 'truth s', 'reported s', 'latency s', 'error m', 'camera', 'people', 'object'], eventRows);
  if (E && E.events) {
    const ev = E.events;
    const kinds = Object.keys(ev.per_kind || {});
    eventsHtml += '<p>Scored by <code>vigil eval</code>:</p>' + table(['kind', 'truth', 'reported', 'matched', 'precision', 'recall', 'latency s', 'error m'],
      kinds.map((k) => { const p = ev.per_kind[k]; return [esc(k), p.truth, p.reported, p.matched, fmt(p.precision), fmt(p.recall), fmt(p.latency_s), fmt(p.localisation_error_m)]; })
        .concat([['<b>all</b>', ev.truth, ev.reported, ev.matched, fmt(ev.precision), fmt(ev.recall), fmt(ev.latency_s), fmt(ev.localisation_error_m)]]));
  }
  $('events').innerHTML = eventsHtml;
  if (E && E.tracking) {
    const tr = E.tracking;
    const row = (name, m) => [esc(name), fmt(m.mota, 3), fmt(m.motp_m, 3), fmt(m.idf1, 3), fmt(m.recall, 3), fmt(m.precision, 3), m.id_switches, m.fragmentations,
      m.false_positives, m.misses, m.ground_truth_count, [m.mostly_tracked, m.partially_tracked, m.mostly_lost].join(' / ')];
    const rows = Object.keys(tr.per_class || {}).map((c) => row(c, tr.per_class[c]));
    rows.push(row('all', tr));
    $('tracking').innerHTML = '<p>' + esc(tr.camera ? 'Where ' + tr.camera + ' looks' : 'All cameras') + (tr.max_range_m ? ', within ' + tr.max_range_m + ' m' : '') +
      ', matched within ' + fmt(tr.match_distance_m) + ' m (MOTChallenge CLEAR MOT and identity measures).</p>' +
      table(['class', 'MOTA', 'MOTP m', 'IDF1', 'recall', 'precision', 'ID sw', 'frag', 'FP', 'misses', 'truth', 'MT / PT / ML'], rows);
  } else {
    $('tracking').innerHTML = '<p class="muted">No eval.json: run <code>vigil eval RUN_DIR</code>, then <code>vigil report</code> again.</p>';
  }
  let robotsHtml = '';
  if (E && E.navigation && E.navigation.robots) {
    robotsHtml += table(['robot', 'reports', 'localised', 'position RMS m', 'worst m', 'heading RMS °', 'goals', 'reached', 'failed', 'time / ideal'],
      E.navigation.robots.map((r) => [esc(r.robot), r.reports, r.localized_reports, fmt(r.position_rms_m, 3), fmt(r.position_worst_m, 3), fmt(r.heading_rms_deg, 2),
        r.goals_started, r.goals_reached, r.goals_failed, fmt(r.median_time_over_ideal, 3)]));
    robotsHtml += '<p>Contacts: ' + E.navigation.contacts_with_people_or_objects + ' with people or objects, ' + E.navigation.contacts_with_robots +
      ' with robots, ' + E.navigation.contacts_with_walls + ' with walls; ' + E.navigation.pushing_contacts + ' pushing.</p>';
  }
  if (E && Array.isArray(E.response) && E.response.length) {
    robotsHtml += '<p>Response to incidents:</p>' + table(['incident', 'kind', 'robot', 'assigned after s', 'travel s', 'best s', 'travel / best', 'cost / best', 'picture'],
      E.response.map((r) => [r.incident, esc(r.kind), esc(r.robot || '–'), fmt(r.time_to_assignment_s), r.arrived ? fmt(r.travel_s) : '<span class="bad">not arrived</span>',
        fmt(r.best_travel_s, 1), fmt(r.travel_over_best, 3), fmt(r.chosen_cost_over_best, 2), r.picture ? '<span class="ok">in view</span>' : '–']), 3);
  }
  $('robots').innerHTML = robotsHtml || '<p class="muted">No robot scores (no robots.jsonl or no eval.json).</p>';

  // ---- Patrol idleness: every vertex's time since its last visit, the mean and the worst ----
  function idlenessPlot(P) {
    const n = P.vertices, visits = (P.visit_log || []).slice().sort((a, b) => a[0] - b[0]);
    const last = new Array(n).fill(0);
    const pts = [];
    let vi = 0;
    for (let t = 0; t <= duration + 1e-9; t += Math.max(0.5, duration / 400)) {
      while (vi < visits.length && visits[vi][0] <= t) { last[visits[vi][1]] = visits[vi][0]; ++vi; }
      let sum = 0, worst = 0;
      for (let k = 0; k < n; ++k) { const idle = t - last[k]; sum += idle; worst = Math.max(worst, idle); }
      pts.push([t, sum / n, worst]);
    }
    const W = 800, H = 220, L = 50, B = 24;
    const ymax = Math.max(1, P.reference_s || 0, ...pts.map((p) => p[2])) * 1.05;
    const X = (t) => L + (W - L - 10) * t / Math.max(duration, 1e-9), Y = (v) => H - B - (H - B - 10) * v / ymax;
    const line = (k) => pts.map((p, i) => (i ? 'L' : 'M') + X(p[0]).toFixed(1) + ',' + Y(p[k]).toFixed(1)).join('');
    let svg = '<svg width="' + W + '" height="' + H + '" font-size="11" font-family="sans-serif">';
    svg += '<line x1="' + L + '" y1="' + (H - B) + '" x2="' + (W - 10) + '" y2="' + (H - B) + '" stroke="#888"/><line x1="' + L + '" y1="10" x2="' + L + '" y2="' + (H - B) + '" stroke="#888"/>';
    for (let k = 0; k <= 4; ++k) { const v = ymax * k / 4; svg += '<text x="4" y="' + (Y(v) + 4) + '">' + v.toFixed(0) + ' s</text>'; }
    for (let k = 0; k <= 4; ++k) { const t = duration * k / 4; svg += '<text x="' + (X(t) - 10) + '" y="' + (H - 6) + '">' + t.toFixed(0) + ' s</text>'; }
    if (P.reference_s) svg += '<line x1="' + L + '" x2="' + (W - 10) + '" y1="' + Y(P.reference_s) + '" y2="' + Y(P.reference_s) + '" stroke="#999" stroke-dasharray="4 3"/><text x="' + (L + 4) + '" y="' + (Y(P.reference_s) - 3) + '" fill="#777">reference (tour / robots / speed)</text>';
    svg += '<path d="' + line(2) + '" fill="none" stroke="#dc0000"/><path d="' + line(1) + '" fill="none" stroke="#0050dc" stroke-width="2"/>';
    svg += '<text x="' + (W - 200) + '" y="20" fill="#0050dc">mean over vertices</text><text x="' + (W - 200) + '" y="34" fill="#dc0000">worst vertex</text></svg>';
    return svg;
  }
  if (E && E.patrol) {
    const P = E.patrol;
    $('idleness').innerHTML = '<p>' + P.vertices + ' vertices, ' + P.robots + ' robots, visits within ' + fmt(P.visit_radius_m) + ' m: average idleness ' + fmt(P.average_s, 1) +
      ' s, worst ' + fmt(P.worst_s, 1) + ' s, ' + P.unvisited + ' never visited; reference ' + fmt(P.reference_s, 1) + ' s.</p>' +
      (P.visit_log ? idlenessPlot(P) : '<p class="muted">eval.json has no visit log (written before 2026-12-06): run vigil eval again.</p>');
  } else {
    $('idleness').innerHTML = '<p class="muted">No patrol scored in this run.</p>';
  }
  $('pictures').innerHTML = D.pictures.length ? D.pictures.map((p) => '<figure><a href="' + esc(p.image) + '"><img src="' + esc(p.image) + '" alt="picture"></a><figcaption>' +
    esc((p.robot || '') + ', incident ' + (p.incident || '') + ' (' + (p.kind || '') + ')' + (p.target_in_view ? ', in view' : ', not in view')) + '</figcaption></figure>').join('')
    : '<p class="muted">No pictures taken.</p>';
  document.querySelectorAll('tr[data-seek]').forEach((tr) => tr.addEventListener('click', () => { setPlaying(false); seek(Number(tr.getAttribute('data-seek'))); window.scrollTo(0, 0); }));

  // ---- Start: #t=SECONDS opens paused at that time ----
  function start() {
    const m = /[#&]t=([0-9.]+)/.exec(window.location.hash);
    const at = m ? Number(m[1]) : 0;
    seek(Number.isFinite(at) ? at : 0);
    document.documentElement.setAttribute('data-ready', '1');
  }
  window.addEventListener('hashchange', () => { setPlaying(false); start(); });
  if (mapImg.complete && mapImg.naturalWidth) start(); else mapImg.addEventListener('load', start);
})();
