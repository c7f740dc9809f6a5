// The delivery scene of the replay page (data: dronefleet.delivery.replay.replay_data).
// The fulfilment centre in the middle, each UAV out along its order's bearing and back,
// coloured by SoC; a strip of every UAV's battery below; deliveries, aborts and losses marked.
function makeScene(d) {
  const f = d.flights, n = d.n_uavs, week = d.week_s;
  const DELIVERED = d.outcomes.indexOf("delivered"), ABORTED = d.outcomes.indexOf("aborted");
  const LOST = d.outcomes.indexOf("lost");
  const rows = f.takeoff_s.map((_, i) => i);
  const ascending = (values, keep) => rows.filter(keep).map(i => values[i]).sort((a, b) => a - b);
  const byTurn = outcome => rows.filter(i => f.outcome[i] === outcome).sort((i, j) => f.turn_s[i] - f.turn_s[j]);
  const delivered = byTurn(DELIVERED), aborted = byTurn(ABORTED);
  const deliveredAt = delivered.map(i => f.turn_s[i]), abortedAt = aborted.map(i => f.turn_s[i]);
  const lostAt = ascending(f.return_s, i => f.outcome[i] === LOST);
  const takeoffs = ascending(f.takeoff_s, () => true), landings = ascending(f.return_s, () => true);
  const ABORT = "#d55e00", DONE = "#333", LINE = "rgba(0, 0, 0, 0.18)";

  /** Distance from the centre [m] of flight k at t (takeoff <= t < return). */
  function along(k, t) {
    if (t < f.turn_s[k]) return f.turn_m[k] * (t - f.takeoff_s[k]) / Math.max(f.turn_s[k] - f.takeoff_s[k], 1e-9);
    const back = (t - f.turn_s[k]) / Math.max(f.return_s[k] - f.turn_s[k], 1e-9);
    return f.turn_m[k] + (f.end_m[k] - f.turn_m[k]) * back;
  }

  /** UAV u at t: {flight, r (m from the centre, if flying), soc [%], lost}. */
  function uavAt(u, t) {
    const first = d.uav_start[u], end = d.uav_start[u + 1], k = upperBound(f.takeoff_s, t, first, end) - 1;
    if (k < first) return { flight: -1, soc: end > first ? f.soc0[first] : null, lost: false };
    const share = (t - f.takeoff_s[k]) / Math.max(f.return_s[k] - f.takeoff_s[k], 1e-9);
    if (t < f.return_s[k]) return { flight: k, r: along(k, t), soc: f.soc0[k] + (f.soc1[k] - f.soc0[k]) * share, lost: false };
    if (f.outcome[k] === LOST) return { flight: k, soc: f.soc1[k], lost: true };
    if (k + 1 >= end) return { flight: -1, soc: f.soc1[k], lost: false };
    const charged = (t - f.return_s[k]) / Math.max(f.takeoff_s[k + 1] - f.return_s[k], 1e-9);
    return { flight: -1, soc: f.soc1[k] + (f.soc0[k + 1] - f.soc1[k]) * charged, lost: false };
  }

  function cross(ctx, x, y, size) {
    ctx.beginPath();
    ctx.moveTo(x - size, y - size); ctx.lineTo(x + size, y + size);
    ctx.moveTo(x - size, y + size); ctx.lineTo(x + size, y - size);
    ctx.stroke();
  }

  function draw(ctx, t, w, h, rate) {
    const strip = Math.min(110, h * 0.2), mapH = h - strip;
    const cx = w / 2, cy = mapH / 2, scale = (Math.min(w, mapH) / 2 - 22) / d.radius_m;
    const at = (r, bearing) => [cx + r * scale * Math.sin(bearing), cy - r * scale * Math.cos(bearing)];
    // distance rings
    ctx.font = "11px system-ui, sans-serif";
    ctx.lineWidth = 1;
    for (const r of niceAxis(0, d.radius_m, 6, false).ticks.filter(r => r > 0)) {
      ctx.strokeStyle = "#ddd";
      ctx.beginPath(); ctx.arc(cx, cy, r * scale, 0, 2 * Math.PI); ctx.stroke();
      ctx.fillStyle = "#999";
      ctx.fillText(`${(r / 1000).toLocaleString("en")} km`, cx + 3, cy - r * scale - 3);
    }
    // deliveries and aborts of the last while: about two seconds on screen at any speed
    const recent = Math.max(1800, 2 * rate);
    const marks = (times, rows, colour, mark) => {
      for (let i = upperBound(times, t - recent); i < upperBound(times, t); i++) {
        const k = rows[i], [x, y] = at(f.turn_m[k], f.bearing[k]);
        ctx.globalAlpha = 1 - (t - times[i]) / recent;
        ctx.strokeStyle = ctx.fillStyle = colour;
        mark(x, y);
      }
      ctx.globalAlpha = 1;
    };
    marks(deliveredAt, delivered, DONE, (x, y) => { ctx.beginPath(); ctx.arc(x, y, 2, 0, 2 * Math.PI); ctx.fill(); });
    ctx.lineWidth = 2;
    marks(abortedAt, aborted, ABORT, (x, y) => cross(ctx, x, y, 5));
    // the fulfilment centre
    ctx.fillStyle = "#222";
    ctx.fillRect(cx - 7, cy - 7, 14, 14);
    ctx.fillText("FC", cx + 10, cy + 4);
    // UAVs: in the air on the map, all in the strip: a bar per UAV on a 0-100 % scale, its
    // number below (every k-th, where they would overlap) and its SoC above (where it fits)
    const left = 46, cell = Math.min(36, (w - left - 10) / n), top = mapH + 24, barH = strip - 42;
    ctx.fillStyle = "#444"; ctx.strokeStyle = "#444"; ctx.lineWidth = 1;
    ctx.fillText("State of charge per UAV [%] (thick outline: in flight, \u2715: lost)", left, mapH + 10);
    ctx.textAlign = "right";
    for (const v of [0, 50, 100]) {
      const y = top + barH * (1 - v / 100);
      ctx.beginPath(); ctx.moveTo(left - 4, y); ctx.lineTo(left, y); ctx.stroke();
      ctx.fillText(String(v), left - 6, y + 4);
    }
    ctx.fillText("UAV", left - 6, top + barH + 13);
    ctx.textAlign = "center";
    const every = Math.ceil((ctx.measureText(String(n - 1)).width + 4) / cell), values = cell >= 24;
    for (let u = 0; u < n; u++) {
      const s = uavAt(u, t), colour = s.soc === null ? "#ccc" : colourOf(s.soc / 100);
      if (s.flight >= 0 && !s.lost) {
        const k = s.flight, [x, y] = at(s.r, f.bearing[k]), [tx, ty] = at(f.turn_m[k], f.bearing[k]);
        ctx.strokeStyle = LINE; ctx.lineWidth = 1;
        ctx.beginPath(); ctx.moveTo(cx, cy); ctx.lineTo(tx, ty); ctx.stroke();
        ctx.fillStyle = colour; ctx.strokeStyle = "#222"; ctx.lineWidth = t < f.turn_s[k] ? 1.5 : 0.5;
        ctx.beginPath(); ctx.arc(x, y, 6, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
        ctx.fillStyle = "#222"; ctx.fillText(String(u), x + 8, y - 6);
      }
      if (s.lost) {
        const k = s.flight, [x, y] = at(f.end_m[k], f.bearing[k]);
        ctx.strokeStyle = "#000"; ctx.lineWidth = 2; cross(ctx, x, y, 6);
      }
      const x0 = left + u * cell, y0 = top;
      ctx.strokeStyle = s.flight >= 0 && !s.lost ? "#222" : "#aaa";
      ctx.lineWidth = s.flight >= 0 && !s.lost ? 2 : 1;
      ctx.strokeRect(x0 + 2, y0, cell - 4, barH);
      if (s.soc !== null && !s.lost) {
        ctx.fillStyle = colour;
        ctx.fillRect(x0 + 3, y0 + barH * (1 - s.soc / 100), cell - 6, barH * s.soc / 100);
      }
      if (s.lost) { ctx.strokeStyle = "#000"; cross(ctx, x0 + cell / 2, y0 + barH / 2, cell / 4); }
      ctx.fillStyle = "#444";
      if (u % every === 0) ctx.fillText(String(u), x0 + cell / 2, y0 + barH + 13);
      if (values && s.soc !== null) {
        ctx.font = "9px system-ui, sans-serif";
        ctx.fillText(s.lost ? "lost" : String(Math.round(s.soc)), x0 + cell / 2, y0 - 3);
        ctx.font = "11px system-ui, sans-serif";
      }
    }
    ctx.textAlign = "left";
  }

  function counters(t) {
    const arrived = upperBound(d.arrival_s, t), done = upperBound(deliveredAt, t);
    const queue = upperBound(d.queue.t_s, t) - 1;
    return [
      ["orders arrived", arrived.toLocaleString("en")],
      ["delivered", done.toLocaleString("en")],
      ["pending", (arrived - done).toLocaleString("en")],
      ["order queue (unallocated)", queue >= 0 ? d.queue.orders[queue].toLocaleString("en") : "0"],
      ["UAVs in flight", String(upperBound(takeoffs, t) - upperBound(landings, t))],
      ["attempts aborted", upperBound(abortedAt, t).toLocaleString("en")],
      ["UAVs lost", String(upperBound(lostAt, t))],
    ];
  }

  function formatTime(t) {
    const day = Math.floor((t % week) / 86400), clock = new Date(Math.round(t % 86400) * 1000).toISOString().slice(11, 19);
    return `week ${Math.floor(t / week) + 1}, day ${day + 1}, ${clock}`;
  }

  return {
    draw, counters, formatTime,
    speeds: [["1 min/s", 60], ["10 min/s", 600], ["1 h/s", 3600], ["6 h/s", 21600], ["1 day/s", 86400]],
    speed: 2,
    chart: { label: "Order queue over the run", t: d.queue.t_s, v: d.queue.orders,
             x: d.duration_s >= 2 * 86400 ? { label: "time [days]", per: 86400 } : { label: "time [h]", per: 3600 },
             y: { label: "unallocated [orders]" } },
    colour: { label: "UAV state of charge [%]", min: "0", max: "100" },
    legend: [["\u25cf", "#222", "UAV in flight (thick ring: outbound)"], ["\u2715", ABORT, "attempt aborted"],
             ["\u2022", DONE, "parcel delivered"], ["\u2715", "#000", "UAV lost"],
             ["", "", "Bearings are drawn from the order id (the model has distances only)."]],
  };
}
