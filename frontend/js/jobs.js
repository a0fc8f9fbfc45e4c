// The status bar: a job's stage and progress, polled with setTimeout until a terminal state.
import { get, post } from "./api.js";

const POLL_MS = 1000;
export const TERMINAL = new Set(["succeeded", "failed", "cancelled"]);

export class JobStatus {
  constructor(root) {
    this.root = root;
    this.text = root.querySelector("#job-text");
    this.bar = root.querySelector("#job-progress");
    this.fill = this.bar.querySelector(".fill");
    this.cancel = root.querySelector("#job-cancel");
    this.cancel.addEventListener("click", () => this.cancelJob());
    this.timer = 0;
    this.token = 0;
    this.job = null;
    this.canCancel = true; // false for a viewer of the job's project
  }

  // Poll the job; onUpdate(job) runs on every answer; resolves with the job once it is terminal.
  watch(jobId, onUpdate = () => {}) {
    this.stop();
    const token = (this.token += 1);
    return new Promise((resolve, reject) => {
      const poll = async () => {
        if (token !== this.token) return;
        try {
          const job = await get(`/jobs/${jobId}`);
          if (token !== this.token) return;
          this.show(job);
          onUpdate(job);
          if (TERMINAL.has(job.state)) resolve(job);
          else this.timer = setTimeout(poll, POLL_MS);
        } catch (error) {
          this.showText(`Lost track of job ${jobId}: ${error.message}`);
          reject(error);
        }
      };
      poll();
    });
  }

  stop() {
    clearTimeout(this.timer);
    this.token += 1;
  }

  show(job) {
    this.job = job;
    const percent = Math.round(100 * (job.progress ?? 0));
    Object.assign(this.root.dataset, { jobId: String(job.id), state: job.state, stage: job.stage ?? "",
      progress: String(job.progress ?? 0), kind: job.kind });
    this.bar.setAttribute("aria-valuenow", String(percent));
    this.bar.hidden = job.state === "queued"; // no bar (full or empty) before the job starts
    this.fill.style.width = `${percent}%`;
    this.text.textContent = statusText(job, percent);
    this.root.dataset.tone = job.state === "failed" ? "error" : "plain"; // a cancel is no error
    this.cancel.hidden = TERMINAL.has(job.state) || !!job.cancel_requested || !this.canCancel;
  }

  // Forget the job (leaving its project): the bar says so, as on a fresh page.
  clear() {
    this.stop();
    this.job = null;
    for (const key of ["jobId", "state", "stage", "progress", "kind", "tone"]) delete this.root.dataset[key];
    this.text.textContent = "No job.";
    this.bar.hidden = true;
    this.cancel.hidden = true;
  }

  showText(text) {
    this.text.textContent = text;
  }

  async cancelJob() {
    if (!this.job) return;
    try {
      await post(`/jobs/${this.job.id}/cancel`);
      this.showText(`Cancelling job ${this.job.id}…`);
    } catch (error) {
      this.showText(`Could not cancel: ${error.message}`);
    }
  }
}

// "Job 7 (apply): running · map · 40%": the stage and percentage only while it runs (an ended
// job's stage is "done", its state says how it ended), the queue position while queued.
function statusText(job, percent) {
  const head = `Job ${job.id} (${job.kind}): ${job.state}`;
  let middle = "";
  if (job.state === "running") {
    middle = `${job.stage && job.stage !== "done" ? ` · ${job.stage}` : ""} · ${percent}%`;
    if (job.cancel_requested) middle += " · cancel requested";
  } else if (job.state === "queued" && job.queue_position) {
    middle = ` · number ${job.queue_position} in the queue`;
  }
  const why = job.state === "failed" ? job.error ?? job.message : job.message;
  return `${head}${middle}${why ? ` · ${why}` : ""}${timingText(job.timings)}`;
}

// " · 42 s (extract 9 s, match 25 s, map 8 s), peak 812 MiB" once the job has ended.
export function timingText(timings) {
  if (!timings?.stages?.length) return "";
  const stages = timings.stages.map((s) => `${s.stage} ${Math.round(s.seconds)} s`).join(", ");
  return ` · ${Math.round(timings.seconds)} s (${stages}), peak ${timings.peak_mb} MiB`;
}
