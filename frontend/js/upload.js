// Adding images (JPEG/PNG or one .zip) with upload progress, and starting a reconstruction.
import { del, post, upload } from "./api.js";

const BATCH = 8; // images per upload request
const BATCH_BYTES = 64 * 1024 * 1024; // and bytes: eight 12 Mpx photos, far under the server's cap

// Consecutive batches of at most `count` files and `bytes` (a larger file goes alone).
export function batchesOf(files, count = BATCH, bytes = BATCH_BYTES) {
  const batches = [];
  let size = 0;
  for (const file of files) {
    const last = batches.at(-1);
    if (!last || last.length >= count || size + file.size > bytes) {
      batches.push([file]);
      size = file.size;
    } else {
      last.push(file);
      size += file.size;
    }
  }
  return batches;
}

// A batch lost on the way (network, 5xx) is sent again whole: the server answers a file it
// already stored (same name and bytes) as `already_uploaded`, never a duplicate or a 409.
const worthResending = (error) => error.status === 0 || error.status >= 500;

// "x.jpg (not a readable JPEG or PNG image)": the server's detail names the file first already.
const reason = (name, detail) => (detail.startsWith(`${name}:`) ? detail : `${name} (${detail})`);

export class UploadPanel {
  constructor(root, { store, projectId, notify, onUploaded, onJob }, signal) {
    Object.assign(this, { root, store, projectId, notify, onUploaded, onJob });
    this.form = root.querySelector("#upload-form");
    this.bar = root.querySelector("#upload-progress");
    this.status = root.querySelector("#upload-status");
    this.form.addEventListener("submit", (e) => { e.preventDefault(); this.send(); }, { signal });
    root.querySelector("#delete-images").addEventListener("click", () => this.deleteSelected(), { signal });
    root.querySelector("#reconstruct-form").addEventListener("submit", (e) => {
      e.preventDefault();
      this.reconstruct(new FormData(e.target));
    }, { signal });
  }

  // Images go in batches of BATCH (each request is all-or-nothing on the server); a refused batch
  // is sent again file by file, so one bad file costs only itself and each is reported.
  async send() {
    const files = [...this.form.querySelector("input[type=file]").files];
    if (!files.length) return this.notify("Choose images (or one .zip) first.");
    this.bar.hidden = false;
    this.setProgress(0);
    const batches = batchesOf(files);
    const stored = [];
    const refused = [];
    let done = 0;
    for (const batch of batches) {
      const part = (f) => this.setProgress((done + f * batch.length) / files.length);
      const outcome = await this.sendBatch(batch, part);
      stored.push(...outcome.stored);
      refused.push(...outcome.refused);
      done += batch.length;
    }
    this.bar.hidden = !stored.length; // no full bar beside a failure
    this.setProgress(1);
    const again = stored.filter((image) => image.already_uploaded).length;
    this.status.textContent = (stored.length ? `Uploaded ${stored.length} images.` : "Nothing was uploaded.") +
      (again ? ` ${again} of them were already in the project (kept once).` : "") +
      (refused.length ? ` Not uploaded: ${refused.join("; ")}.` : "");
    this.root.dataset.uploaded = String(stored.length);
    this.root.dataset.refused = String(refused.length);
    if (!refused.length) this.form.reset();
    if (stored.length) this.onUploaded(stored);
  }

  async sendBatch(batch, progress) {
    const post1 = (files) => {
      const data = new FormData();
      for (const file of files) data.append("files", file);
      return upload(`/projects/${this.projectId}/images`, data, progress);
    };
    try {
      return { stored: await post1(batch).catch((error) => {
        if (!worthResending(error)) throw error;
        return post1(batch);
      }), refused: [] };
    } catch (error) {
      if (batch.length === 1) return { stored: [], refused: [reason(batch[0].name, error.message)] };
      const out = { stored: [], refused: [] };
      for (const file of batch) {
        const one = await this.sendBatch([file], () => {});
        out.stored.push(...one.stored);
        out.refused.push(...one.refused);
      }
      return out;
    }
  }

  // Delete the selected images, one request each; the server refuses those a version uses
  // (design.md v1.1), and each answer is reported.
  async deleteSelected() {
    const ids = [...this.store.selection];
    if (!ids.length) return this.notify("Select the images to delete first (in the strip).");
    const names = ids.map((id) => this.store.byId.get(id)?.name ?? `#${id}`);
    if (!window.confirm(`Delete ${names.length} image(s): ${names.join(", ")}? This cannot be undone.`)) return;
    const outcome = [];
    for (const [i, id] of ids.entries()) {
      try {
        await del(`/projects/${this.projectId}/images/${id}`);
        outcome.push(`${names[i]} deleted`);
      } catch (error) {
        outcome.push(`${names[i]} kept: ${error.message}`);
      }
    }
    this.status.textContent = outcome.join("; ");
    if (outcome.some((o) => o.endsWith(" deleted"))) this.onUploaded([]);
  }

  setProgress(fraction) {
    const percent = Math.round(100 * Math.min(1, fraction));
    this.bar.querySelector(".fill").style.width = `${percent}%`;
    this.bar.setAttribute("aria-valuenow", String(percent));
    this.status.textContent = `Uploading… ${percent}%`;
  }

  // A fresh start over repaired versions is confirmed first: it maps the raw matches again.
  async reconstruct(form) {
    const { version, cameras } = this.store;
    if (!cameras.length) return this.notify("Upload images first: there is nothing to reconstruct.");
    const question = `Reconstruct from scratch? This maps all ${cameras.length} images again from their ` +
      `raw matches and makes a new head; your repairs in v${version?.id} stay in the version list but ` +
      "are not carried over. To apply edits, use \"Run reconstruction\" in the toolbar instead.";
    if (version && !window.confirm(question)) return;
    const body = { matcher: form.get("matcher"), mapper: form.get("mapper") };
    try {
      const job = await post(`/projects/${this.projectId}/reconstruct`, body);
      this.notify(`Reconstruction queued (job ${job.id}).`);
      this.onJob(job);
    } catch (error) {
      this.notify(`Could not start the reconstruction: ${error.message}`, "error");
    }
  }
}
