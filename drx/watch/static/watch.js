// drx watch: the page's script. Plain JavaScript, no build step.
// State arrives once a second as server-sent events (/events); the pictures are MJPEG streams
// (/stream/top.mjpg, /stream/camera.mjpg); the reward graph is uPlot (MIT, vendored in /static).
"use strict";

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const asked = params.get("model");
const watch = { state: null, chart: null, points: 0, model: undefined, events: 0 };
window.drxWatch = watch; // for the browser tests and the curious

const COLORS = { reward: "#3ecf8e", train: "#4ea1ff", evaluation: "#ff6b6b", axis: "#8d9bb0", grid: "#263244" };

function fmt(value, digits = 1, unit = "") {
  if (value === null || value === undefined || Number.isNaN(value)) return "—";
  return Number(value).toFixed(digits) + unit;
}

function clock(seconds) {
  if (seconds === null || seconds === undefined) return "—";
  const s = Math.max(0, Math.round(seconds));
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), r = s % 60;
  return `${h}:${String(m).padStart(2, "0")}:${String(r).padStart(2, "0")}`;
}

function phaseKind(phase, job) {
  if (phase.startsWith("sampling")) return "sampling";
  if (phase.startsWith("updating")) return "updating";
  if (phase.startsWith("evaluating") || phase.startsWith("racing")) return "evaluating";
  if (!job) return "idle";
  if (job.status === "failed") return "failed";
  if (job.status === "succeeded" || job.status === "stopped") return "done";
  return "idle";
}

function makeChart() {
  const el = $("chart");
  const axis = { stroke: COLORS.axis, grid: { stroke: COLORS.grid, width: 1 }, ticks: { stroke: COLORS.grid } };
  const opts = {
    width: el.clientWidth || 800,
    height: 300,
    scales: { x: { time: false }, reward: { auto: true }, pct: { range: [0, 100] } },
    series: [
      { label: "iteration", value: (u, v) => (v === null ? "—" : v) },
      { label: "Average reward (training)", scale: "reward", stroke: COLORS.reward, width: 2,
        points: { size: 6, fill: COLORS.reward }, spanGaps: true, value: (u, v) => fmt(v, 2) },
      { label: "Average % completion (training)", scale: "pct", stroke: COLORS.train, width: 2,
        points: { size: 6, fill: COLORS.train }, spanGaps: true, value: (u, v) => fmt(v, 1, "%") },
      { label: "Average % completion (evaluation)", scale: "pct", stroke: COLORS.evaluation, width: 2,
        dash: [6, 4], points: { size: 6, fill: COLORS.evaluation }, spanGaps: true, value: (u, v) => fmt(v, 1, "%") },
    ],
    axes: [
      { ...axis, label: "iteration", labelSize: 20, incrs: [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000] },
      { ...axis, scale: "reward", label: "reward", labelSize: 24 },
      { ...axis, scale: "pct", side: 1, label: "% track completion", labelSize: 24, grid: { show: false },
        values: (u, ticks) => ticks.map((t) => t + "%") },
    ],
    legend: { live: true },
    cursor: { points: { size: 8 } },
    // Away from the cursor the legend shows the last iteration's values, as a reading of "now".
    hooks: { setCursor: [(u) => { if (u.cursor.idx == null) showLast(u); }] },
  };
  const chart = new uPlot(opts, [[], [], [], []], el);
  new ResizeObserver(() => chart.setSize({ width: el.clientWidth, height: 300 })).observe(el);
  return chart;
}

function showLast(u) {
  const n = u.data[0].length;
  if (n) u.setLegend({ idx: n - 1 });
}

function updateChart(graph) {
  const n = graph.iteration.length;
  const data = [graph.iteration, graph.train_reward, graph.train_progress, graph.eval_progress];
  const key = JSON.stringify(data);
  if (key === watch.chartKey) return;
  watch.chartKey = key;
  watch.chart.setData(data);
  if (watch.chart.cursor.idx == null) showLast(watch.chart);
  watch.points = n;
  $("chart-empty").style.display = n ? "none" : "block";
  $("graph-hint").textContent = n ? `${n} iteration${n === 1 ? "" : "s"}` : "per iteration";
}

function setStreams(model) {
  if (model === watch.model) return;
  watch.model = model;
  const q = model ? `?model=${encodeURIComponent(model)}` : "";
  // A new URL per model: the browser opens the new stream and drops the old one.
  for (const [id, view] of [["top", "top"], ["camera", "camera"]]) {
    if (model) $(id).src = `/stream/${view}.mjpg${q}`;
    else $(id).removeAttribute("src");
  }
}

function figureRows(s) {
  const f = s.figures || {}, job = s.job, pose = s.pose, rows = [];
  if (job) {
    rows.push(["Job", `#${job.id} ${job.kind} · ${job.status}`]);
    if (job.worker) rows.push(["Worker", job.worker]);
    if (job.elapsed !== null && job.elapsed !== undefined) {
      let time = clock(job.elapsed);
      if (f.max_minutes && job.kind === "train") time += ` / ${clock(f.max_minutes * 60)}`;
      rows.push(["Elapsed", time]);
    }
  }
  if (!job || job.kind === "train") {
    const per = f.episodes_per_iteration ? ` (${f.iteration_episodes}/${f.episodes_per_iteration} episodes)` : "";
    rows.push(["Iteration", `${f.iteration ?? 0}${per}`]);
    rows.push(["Episodes", f.episodes ?? 0]);
    rows.push(["Steps", (f.steps ?? 0).toLocaleString()]);
    rows.push(["Steps / s", fmt(f.steps_per_second, 0)]);
    if (f.best_iteration !== null && f.best_iteration !== undefined)
      rows.push(["Best model", `iteration ${f.best_iteration} · ${fmt(f.best_eval_progress, 1, "%")}`]);
    if (f.best_lap_time) rows.push(["Best lap", fmt(f.best_lap_time, 3, " s")]);
  } else if (f.race_status) {
    rows.push(["Laps", f.race_laps]);
    rows.push(["Fastest lap", fmt(f.race_fastest_lap, 3, " s")]);
  }
  if (pose) {
    rows.push(["Car", `${fmt(pose.speed, 2, " m/s")} · ${fmt(pose.progress, 1, "%")} · ${pose.status}`]);
  }
  return rows;
}

function render(s) {
  watch.state = s;
  watch.events += 1;
  if (s.error) {
    $("phase").textContent = "error";
    $("phase").dataset.kind = "failed";
    $("subtitle").textContent = s.error;
    return;
  }
  $("model").textContent = s.model || "waiting for a model";
  // the track of the episode in progress (a model on several tracks changes between episodes)
  const driving = (s.pose && s.pose.track) || s.track;
  const tracks = (s.tracks || []).length > 1 ? ` (tracks in turn: ${s.tracks.join(", ")})` : "";
  $("subtitle").textContent = s.model
    ? `${driving}${tracks} · car ${s.car} · ${s.network} network · ${String(s.algorithm).toUpperCase()}`
    : "Create a model and train it; this page follows the newest job.";
  $("phase").textContent = s.phase;
  $("phase").title = s.phase; // a long error is cut in the pill, whole here (and in the Job card)
  $("phase").dataset.kind = phaseKind(s.phase, s.job);
  document.title = s.model ? `${s.model} · ${s.phase} · drx watch` : "drx watch";

  const dl = $("figures");
  dl.replaceChildren();
  for (const [k, v] of figureRows(s)) {
    const dt = document.createElement("dt"), dd = document.createElement("dd");
    dt.textContent = k;
    dd.textContent = v;
    dl.append(dt, dd);
  }
  const problem = (s.job && s.job.status === "failed" && s.job.error) || s.frames_error;
  if (problem) {
    const dd = document.createElement("dd");
    dd.className = "error";
    dd.textContent = problem;
    dl.append(dd);
  }
  $("job-hint").textContent = s.model_status ? `model ${s.model_status}` : "";
  const pose = s.pose;
  $("sim-hint").textContent = pose
    ? `${pose.mode} episode ${pose.episode} on ${pose.track} · step ${pose.steps}` + (pose.age > 2 ? ` · ${Math.round(pose.age)} s ago` : "")
    : "no car on the track yet";

  const nav = $("jobs");
  nav.replaceChildren();
  for (const j of s.jobs || []) {
    const a = document.createElement("a");
    a.href = `/?model=${encodeURIComponent(j.model)}`;
    a.textContent = `${j.model} · ${j.kind} #${j.id} ${j.status}`;
    if (j.model === s.model) a.className = "current";
    nav.append(a);
  }
  setStreams(s.model);
  updateChart(s.graph);
}

function connect() {
  const source = new EventSource("/events" + (asked ? `?model=${encodeURIComponent(asked)}` : ""));
  source.onmessage = (e) => render(JSON.parse(e.data));
  source.onerror = () => {
    $("phase").textContent = "reconnecting";
    $("phase").dataset.kind = "idle";
  };
}

watch.chart = makeChart();
connect();
