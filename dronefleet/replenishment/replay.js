// The replenishment scene of the replay page (data: dronefleet.replenishment.replay.replay_data).
// The arena seen from above: base, transfer and work areas, workers (discs) and mobile
// chargers (squares) coloured by their battery, moving between the frames by interpolation.
function makeScene(d) {
  const n = d.n_workers + d.n_chargers, frames = d.work.length;
  const FILL = { base: "#cfd9e6", transfer: "#f4e2c4", work: "#d6ebd1" };
  const LABEL = { base: "base (charging)", transfer: "transfer", work: "work" };
  const EMPTY = "#d55e00";  // vermillion, on a white halo: seen on the darkest disc and on the floor

  /** [frame index, weight of the next frame] at time t. */
  function frameAt(t) {
    const position = Math.min(Math.max(t / d.frame_s, 0), frames - 1), i = Math.min(Math.floor(position), Math.max(frames - 2, 0));
    return [i, frames > 1 ? position - i : 0];
  }
  const value = (column, i, a, robot) =>
    a > 0 ? column[i * n + robot] + a * (column[(i + 1) * n + robot] - column[i * n + robot]) : column[i * n + robot];

  function draw(ctx, t, w, h) {
    const wall = d.wall_m, scale = (Math.min(w, h) - 40) / (2 * wall), cx = w / 2, cy = h / 2;
    const X = x => cx + x * scale, Y = y => cy - y * scale;
    ctx.fillStyle = "#fff"; ctx.strokeStyle = "#444"; ctx.lineWidth = 2;
    ctx.fillRect(X(-wall), Y(wall), 2 * wall * scale, 2 * wall * scale);
    ctx.font = "12px system-ui, sans-serif";
    for (const [name, [x0, x1, y0, y1]] of Object.entries(d.areas)) {
      const left = Math.max(x0, -wall), right = Math.min(x1, wall), bottom = Math.max(y0, -wall), top = Math.min(y1, wall);
      ctx.fillStyle = FILL[name];
      ctx.fillRect(X(left), Y(top), (right - left) * scale, (top - bottom) * scale);
      ctx.fillStyle = "#555";
      ctx.fillText(LABEL[name], X(left) + 4, Y(top) + 14);
    }
    ctx.strokeRect(X(-wall), Y(wall), 2 * wall * scale, 2 * wall * scale);
    const [i, a] = frameAt(t), size = Math.max(d.radius_m * scale, 4);
    for (let robot = 0; robot < n; robot++) {
      const x = X(value(d.x, i, a, robot)), y = Y(value(d.y, i, a, robot));
      const fraction = value(d.energy, i, a, robot) / d.capacity[robot];
      ctx.fillStyle = colourOf(fraction); ctx.strokeStyle = "#222";
      ctx.beginPath();
      if (robot < d.n_workers) { ctx.lineWidth = 1; ctx.arc(x, y, size, 0, 2 * Math.PI); }
      else { ctx.lineWidth = 2; ctx.rect(x - size, y - size, 2 * size, 2 * size); }
      ctx.fill(); ctx.stroke();
      if (fraction <= 0) {
        ctx.beginPath(); ctx.moveTo(x - size, y - size); ctx.lineTo(x + size, y + size);
        ctx.moveTo(x - size, y + size); ctx.lineTo(x + size, y - size);
        ctx.lineCap = "round";
        ctx.strokeStyle = "#fff"; ctx.lineWidth = 6; ctx.stroke();
        ctx.strokeStyle = EMPTY; ctx.lineWidth = 3; ctx.stroke();
        ctx.lineCap = "butt";
      }
    }
  }

  function counters(t) {
    const [i, a] = frameAt(t), k = a < 0.5 ? i : i + 1, rows = [
      ["work [points]", d.work[k].toLocaleString("en")],
      ["energy stored", d.stored[k].toLocaleString("en", { maximumFractionDigits: 0 })],
    ];
    const count = (first, last, phase) => {
      let c = 0;
      for (let r = first; r < last; r++) c += d.phase[k * n + r] === phase;
      return String(c);
    };
    d.phases.workers.forEach((name, p) => rows.push([`workers ${name.replace("_", " ")}`, count(0, d.n_workers, p)]));
    if (d.n_chargers > 0) {
      d.phases.chargers.forEach((name, p) => rows.push([`chargers ${name.replace("_", " ")}`, count(d.n_workers, n, p)]));
    }
    return rows;
  }

  return {
    draw, counters,
    formatTime: t => `${t.toFixed(1)} s of ${d.duration_s.toFixed(1)} s`,
    speeds: [["1x", 1], ["2x", 2], ["5x", 5], ["10x", 10], ["30x", 30], ["100x", 100]],
    speed: 3,
    chart: { label: "Energy stored in all batteries", t: d.work.map((_, i) => i * d.frame_s), v: d.stored,
             x: { label: "time [s]", per: 1 }, y: { label: "stored [energy units]" } },
    colour: { label: "Battery [fraction of capacity]", min: "0", max: "1" },
    legend: [["\u25cf", "#222", "worker"], ...(d.n_chargers > 0 ? [["\u25a0", "#222", "mobile charger"]] : []),
             ["\u2715", EMPTY, "battery empty"]],
  };
}
