// The items scene of the replay page (data: dronefleet.items.replay.replay_data).
// The unit square from above: home at the centre, the locations sized and coloured by what waits
// there, the robots moving on straight lines between nodes with their payload as a red wedge
// (and a number, for up to 12 robots);
// beside it, the served share over time on axes. One page second is one step.
function makeScene(d) {
  const n = d.n_robots, m = d.loc_x.length, steps = d.duration_s, logistic = d.truth === "logistic";
  const foraging = d.mode === "foraging";
  const share = d.served.map((s, i) => logistic ? s : (d.generated[i] > 0 ? 100 * s / d.generated[i] : 0));
  let countTop = 1;
  for (const c of d.counts) if (c > countTop) countTop = c;
  const shareTop = logistic ? d.served.reduce((a, b) => Math.max(a, b), 1) : 100;
  const what = logistic ? "population x_j" : foraging ? "items waiting" : "demands waiting";
  const ROBOT = "#c0392b";

  /** [step before t, weight of the next step] and the step whose counts show at t. */
  function stepAt(t) {
    const position = Math.min(Math.max(t, 0), steps), i = Math.min(Math.floor(position), steps - 1);
    return [i, position - i, Math.min(Math.floor(position), steps)];
  }
  const between = (column, i, a, robot) =>
    column[i * n + robot] + a * (column[(i + 1) * n + robot] - column[i * n + robot]);

  /** Where the world and the chart go: side by side on a wide view, stacked on a tall one. */
  function layout(w, h) {
    const wide = w >= 1.3 * h;
    const side = Math.max(40, wide ? Math.min(h - 40, 0.62 * w - 40) : Math.min(w - 40, 0.62 * h - 40));
    const world = { left: 20, top: 20, side };
    const chart = wide ? { left: side + 80, top: 30, right: w - 20, bottom: h - 50 }
                       : { left: 60, top: side + 50, right: w - 20, bottom: h - 40 };
    return { world, chart };
  }
  let shown = null;  // what the last frame drew, for the hover text: [layout, step]

  function locationRadius(side) {
    const most = Math.max(2, Math.min(12, 0.45 * side / (Math.sqrt(m) + 1)));
    return c => most * (0.3 + 0.7 * Math.sqrt(Math.max(0, c) / countTop));
  }

  function drawWorld(ctx, box, k, i, a) {
    const { left, top, side } = box, X = x => left + x * side, Y = y => top + (1 - y) * side;
    ctx.fillStyle = "#fff"; ctx.strokeStyle = "#444"; ctx.lineWidth = 1.5;
    ctx.fillRect(left, top, side, side); ctx.strokeRect(left, top, side, side);
    const radius = locationRadius(side), few = m <= 40;
    ctx.font = "11px system-ui, sans-serif"; ctx.lineWidth = 0.5;
    for (let j = 0; j < m; j++) {
      const c = d.counts[k * m + j], x = X(d.loc_x[j]), y = Y(d.loc_y[j]);
      ctx.fillStyle = colourOf(c / countTop); ctx.strokeStyle = "#333";
      ctx.beginPath(); ctx.arc(x, y, radius(c), 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      if (few) { ctx.fillStyle = "#222"; ctx.fillText(String(Math.floor(c)), x + radius(c) + 2, y - 2); }
    }
    const hx = X(d.home[0]), hy = Y(d.home[1]);
    ctx.fillStyle = "#333"; ctx.fillRect(hx - 7, hy - 7, 14, 14);
    ctx.fillStyle = "#333"; ctx.font = "12px system-ui, sans-serif"; ctx.fillText("home", hx + 10, hy + 16);
    ctx.font = "bold 11px system-ui, sans-serif";
    for (let robot = 0; robot < n; robot++) {
      const x = X(between(d.x, i, a, robot)), y = Y(between(d.y, i, a, robot));
      const payload = d.payload[k * n + robot], load = payload / d.capacity;
      ctx.fillStyle = "#fff"; ctx.strokeStyle = ROBOT; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.arc(x, y, 7, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      if (load > 0) {
        ctx.fillStyle = ROBOT;
        ctx.beginPath(); ctx.moveTo(x, y); ctx.arc(x, y, 7, -Math.PI / 2, -Math.PI / 2 + 2 * Math.PI * Math.min(1, load));
        ctx.closePath(); ctx.fill();
        if (n <= 12) ctx.fillText(String(payload), x - 9 - ctx.measureText(String(payload)).width, y - 7);
      }
    }
  }

  function drawChart(ctx, box, k) {
    const { left, top, right, bottom } = box;
    if (right - left < 40 || bottom - top < 40) return;
    const X = s => left + (right - left) * s / steps, Y = v => bottom - (bottom - top) * v / shareTop;
    ctx.strokeStyle = "#444"; ctx.lineWidth = 1; ctx.fillStyle = "#444"; ctx.font = "11px system-ui, sans-serif";
    ctx.beginPath(); ctx.moveTo(left, top); ctx.lineTo(left, bottom); ctx.lineTo(right, bottom); ctx.stroke();
    ctx.textAlign = "center";
    for (const s of niceAxis(0, steps, 5, false).ticks) {
      ctx.beginPath(); ctx.moveTo(X(s), bottom); ctx.lineTo(X(s), bottom + 4); ctx.stroke();
      ctx.fillText(String(s), X(s), bottom + 16);
    }
    ctx.fillText("step", (left + right) / 2, bottom + 32);
    ctx.textAlign = "right";
    for (const v of niceAxis(0, shareTop, 5, false).ticks) {
      ctx.strokeStyle = "#e4e4e4"; ctx.beginPath(); ctx.moveTo(left + 1, Y(v)); ctx.lineTo(right, Y(v)); ctx.stroke();
      ctx.fillText(String(v), left - 6, Y(v) + 4);
    }
    ctx.textAlign = "left";
    ctx.fillText(logistic ? "foraged [items]" : `served [% of generated]`, left, top - 10);
    const stride = Math.max(1, Math.floor(steps / (right - left)));  // about a point per pixel
    const path = (from, to) => {
      ctx.beginPath(); ctx.moveTo(X(from), Y(share[from]));
      for (let s = from + stride; s < to; s += stride) ctx.lineTo(X(s), Y(share[s]));
      ctx.lineTo(X(to), Y(share[to])); ctx.stroke();
    };
    ctx.lineWidth = 1; ctx.strokeStyle = "#c9d3e3"; path(0, steps);      // the whole run, faint
    ctx.lineWidth = 2; ctx.strokeStyle = "#4a6fa5"; path(0, k);          // so far
    ctx.fillStyle = "#4a6fa5"; ctx.beginPath(); ctx.arc(X(k), Y(share[k]), 3.5, 0, 2 * Math.PI); ctx.fill();
  }

  function draw(ctx, t, w, h) {
    const [i, a, k] = stepAt(t), boxes = layout(w, h);
    drawWorld(ctx, boxes.world, k, i, a);
    drawChart(ctx, boxes.chart, k);
    shown = [boxes.world, k];
  }

  // The count (and true rate) of the location under the pointer, in a box over the map.
  const view = document.getElementById("view"), tip = document.createElement("div");
  tip.style.cssText = "position:absolute;display:none;pointer-events:none;padding:2px 6px;background:#fff;" +
                      "border:1px solid #999;font:12px system-ui,sans-serif;white-space:nowrap";
  view.append(tip);
  view.addEventListener("mousemove", event => {
    if (shown === null) return;
    const [{ left, top, side }, k] = shown, box = view.getBoundingClientRect();
    const px = event.clientX - box.left, py = event.clientY - box.top, radius = locationRadius(side);
    let best = -1, nearest = Infinity;
    for (let j = 0; j < m; j++) {
      const dx = left + d.loc_x[j] * side - px, dy = top + (1 - d.loc_y[j]) * side - py, r2 = dx * dx + dy * dy;
      if (r2 < nearest && r2 <= (radius(countTop) + 3) ** 2) { best = j; nearest = r2; }
    }
    if (best < 0) { tip.style.display = "none"; return; }
    const rate = d.loc_rate === null ? "" : `, ${d.truth === "bernoulli" ? "p" : "\u03bb"} ${d.loc_rate[best]}`;
    tip.textContent = `location ${best + 1}: ${d.counts[k * m + best]} ${what}${rate}`;
    tip.style.left = `${px + 12}px`; tip.style.top = `${py + 12}px`; tip.style.display = "block";
  });
  view.addEventListener("mouseleave", () => { tip.style.display = "none"; });

  function counters(t) {
    const k = stepAt(t)[2];
    let carried = 0, waiting = 0;
    for (let robot = 0; robot < n; robot++) carried += d.payload[k * n + robot];
    for (let j = 0; j < m; j++) waiting += d.counts[k * m + j];
    const whole = v => Math.floor(v).toLocaleString("en");
    return [
      ["step", String(k)],
      [logistic ? "net growth (A19)" : "generated", whole(d.generated[k])],
      [logistic ? "foraged" : "served", whole(d.served[k])],
      ...(logistic ? [] : [["served share", `${share[k].toFixed(1)} %`]]),
      ["carried by robots", whole(carried)],
      [logistic ? "population" : what, whole(waiting)],
    ];
  }

  const rates = [1, 2, 5, 10, 20, 50, 100, 200, 500];
  return {
    draw, counters,
    formatTime: t => `step ${Math.floor(t)} of ${steps}`,
    speeds: rates.map(r => [`${r} steps/s`, r]),
    speed: Math.max(0, rates.findLastIndex(r => r <= steps / 30)),  // a run in about half a minute
    chart: { label: logistic ? "Foraged over the run" : "Served share over the run", t: share.map((_, s) => s), v: share,
             x: { label: "step", per: 1 }, y: { label: logistic ? "foraged [items]" : "served [% of generated]" } },
    colour: { label: `Location: ${what}`, min: "0", max: countTop.toLocaleString("en") },
    legend: [["\u25a0", "#333", "home"], ["\u25cf", colourOf(0.6), `location (size, colour: ${what})`],
             ["\u25d4", ROBOT, "robot (red share, number: payload)"]],
  };
}
