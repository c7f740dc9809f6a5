// The lunar scene of the replay page (data: dronefleet.lunar.replay.replay_data).
// The walled field from above: regions N, T, R as discs, the obstacle (hard: solid grey; soft:
// dashed and hatched, passable), beacons as black squares with a guidance vector per key (T
// orange, N blue, R green; 0.8 m for |v| = v0), mobile robots as discs ringed by their role's
// colour and filled by their state of charge (viridis), charging robots ringed twice, the dead
// as vermillion crosses; beside it the resources returned over the run. Positions move
// linearly between frames (one every n_T ticks); everything else shows the frame at or before t.
function makeScene(d) {
  const n = d.n_robots, frames = d.times.length, duration = d.duration_s;
  const KEYS = ["T", "N", "R"], KEY_COLOUR = { T: "#E69F00", N: "#0072B2", R: "#009E73" };
  // state codes of dronefleet.lunar.replay.ROLE_CODES
  const ROLE_COLOUR = ["#E69F00", "#0072B2", "#009E73", "#000000"], DEAD = "#D55E00";
  const ARROW_M = 0.8;

  /** [frame at or before t, next frame, weight of the next] */
  function frameAt(t) {
    const i = Math.max(0, upperBound(d.times, t) - 1), j = Math.min(i + 1, frames - 1);
    const a = j > i ? Math.min(1, Math.max(0, (t - d.times[i]) / (d.times[j] - d.times[i]))) : 0;
    return [i, j, a];
  }
  const at = (column, i, j, a, robot) => column[i * n + robot] + a * (column[j * n + robot] - column[i * n + robot]);
  /** The last series index at or before t. */
  const seriesAt = t => Math.max(0, upperBound(d.series_t, t) - 1);

  function draw(ctx, t, w, h) {
    const [fw, fh] = d.field, margin = 16;
    const scale = Math.max(1, Math.min((w - 2 * margin) / fw, (h - 2 * margin) / fh));
    const X = x => margin + x * scale, Y = y => margin + (fh - y) * scale;
    ctx.fillStyle = "#fff"; ctx.fillRect(X(0), Y(fh), fw * scale, fh * scale);
    for (const key of KEYS) {
      const [x, y, r] = d.regions[key];
      ctx.globalAlpha = 0.18; ctx.fillStyle = KEY_COLOUR[key];
      ctx.beginPath(); ctx.arc(X(x), Y(y), r * scale, 0, 2 * Math.PI); ctx.fill();
      ctx.globalAlpha = 1; ctx.strokeStyle = KEY_COLOUR[key]; ctx.lineWidth = 1; ctx.stroke();
      ctx.fillStyle = KEY_COLOUR[key]; ctx.font = "bold 14px system-ui, sans-serif"; ctx.textAlign = "center";
      ctx.fillText(key, X(x), Y(y) + 5);
    }
    if (d.obstacle !== null) {
      ctx.beginPath();
      d.obstacle.forEach(([x, y], k) => (k ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y))));
      ctx.closePath();
      if (d.obstacle_kind === "hard") {
        ctx.fillStyle = "#595959"; ctx.fill(); ctx.strokeStyle = "#000"; ctx.setLineDash([]); ctx.stroke();
      } else {
        ctx.fillStyle = "#e8dcc4"; ctx.fill(); ctx.strokeStyle = "#4d4d4d"; ctx.setLineDash([5, 3]); ctx.stroke();
        ctx.setLineDash([]);
      }
    }
    ctx.strokeStyle = "#000"; ctx.lineWidth = 2.5; ctx.strokeRect(X(0), Y(fh), fw * scale, fh * scale);
    const [i, j, a] = frameAt(t), radius = Math.max(3, 0.15 * scale);
    for (let robot = 0; robot < n; robot++) {
      const state = d.state[i * n + robot];
      if (state === 5) continue;   // not spawned yet
      const x = X(at(d.x, i, j, a, robot)), y = Y(at(d.y, i, j, a, robot));
      if (state === 4) {
        ctx.strokeStyle = DEAD; ctx.lineWidth = 2;
        ctx.beginPath(); ctx.moveTo(x - radius, y - radius); ctx.lineTo(x + radius, y + radius);
        ctx.moveTo(x - radius, y + radius); ctx.lineTo(x + radius, y - radius); ctx.stroke();
        continue;
      }
      ctx.fillStyle = colourOf(d.soc[i * n + robot]);
      ctx.strokeStyle = state === 6 ? ROLE_COLOUR[2] : ROLE_COLOUR[state]; ctx.lineWidth = 2;
      ctx.beginPath();
      if (state === 3) {   // a beacon: a smaller square, its vectors drawn over it
        const half = 0.7 * radius;
        ctx.rect(x - half, y - half, 2 * half, 2 * half); ctx.fill(); ctx.lineWidth = 1.5; ctx.stroke();
        ctx.lineWidth = 2;
        for (const key of KEYS) {
          const vx = d[`vx_${key}`][i * n + robot], vy = d[`vy_${key}`][i * n + robot];
          if (vx === 0 && vy === 0) continue;
          const k = ARROW_M / d.v0 * scale;
          ctx.strokeStyle = KEY_COLOUR[key];
          ctx.beginPath(); ctx.moveTo(x, y); ctx.lineTo(x + vx * k, y - vy * k); ctx.stroke();
        }
        continue;
      }
      ctx.arc(x, y, radius, 0, 2 * Math.PI);
      ctx.fill(); ctx.stroke();
      if (state === 6) { ctx.beginPath(); ctx.arc(x, y, radius + 3, 0, 2 * Math.PI); ctx.stroke(); }
      if (d.load[i * n + robot] > 0) { ctx.fillStyle = "#000"; ctx.fillRect(x - 1.5, y - 1.5, 3, 3); }
    }
  }

  function counters(t) {
    const [i] = frameAt(t), s = seriesAt(t);
    let charging = 0, socSum = 0, alive = 0;
    for (let robot = 0; robot < n; robot++) {
      const state = d.state[i * n + robot];
      if (state === 6) charging++;
      if (state !== 4 && state !== 5) { alive++; socSum += d.soc[i * n + robot]; }
    }
    const count = v => v.toLocaleString("en");
    return [
      ["frame time [s]", d.times[i].toFixed(1)],
      ["resources returned", count(d.resources[s])],
      ["mobile robots", count(d.n_mobile[s])],
      ["beacons", count(d.n_beacons[s])],
      ["charging", count(charging)],
      ["dead", count(d.n_dead[s])],
      ["mean SOC of the alive", alive ? (socSum / alive).toFixed(2) : "-"],
    ];
  }

  const rates = [1, 2, 5, 10, 20, 50, 100, 200];
  return {
    draw, counters,
    formatTime: t => `t = ${t.toFixed(0)} s of ${duration.toFixed(0)} s`,
    speeds: rates.map(r => [`${r} s/s`, r]),
    speed: Math.max(0, rates.findLastIndex(r => r <= duration / 60)),  // a run in about a minute
    chart: { label: "Resources returned over the run", t: d.series_t, v: d.resources,
             x: { label: "time [min]", per: 60 }, y: { label: "resources [units]" } },
    colour: { label: "Robot fill: state of charge", min: "0", max: "1" },
    legend: [["\u25a0", "#000000", "beacon"], ...KEYS.map(key => ["\u2500", KEY_COLOUR[key], `beacon's vector to ${key}`]),
             ["\u25cb", ROLE_COLOUR[0], "F_OUT, to T"], ["\u25cb", ROLE_COLOUR[1], "F_IN, to N (dot: loaded)"],
             ["\u25cb", ROLE_COLOUR[2], "R, to recharge (double ring: charging)"], ["\u00d7", DEAD, "dead"]],
  };
}
