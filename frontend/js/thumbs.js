// Thumbnails fetched with the token (an <img> cannot send one), when they scroll into view.
import { blobUrl } from "./api.js";

const PARALLEL = 4;
const cache = new Map(); // "pid/id" -> Promise<object URL>
let active = 0;
const waiting = [];

function schedule(task) {
  return new Promise((resolve, reject) => {
    waiting.push(() => task().then(resolve, reject));
    pump();
  });
}

function pump() {
  while (active < PARALLEL && waiting.length) {
    active += 1;
    waiting.shift()().finally(() => { active -= 1; pump(); });
  }
}

export function thumbnailUrl(projectId, imageId) {
  const key = `${projectId}/${imageId}`;
  if (!cache.has(key)) {
    const path = `/projects/${projectId}/images/${imageId}/thumbnail`;
    cache.set(key, schedule(() => blobUrl(path)).catch((error) => { cache.delete(key); throw error; }));
  }
  return cache.get(key);
}

export class ThumbnailLoader {
  constructor(projectId, scrollRoot) {
    this.projectId = projectId;
    this.observer = new IntersectionObserver((entries) => this.onVisible(entries),
      { root: scrollRoot, rootMargin: "200px" });
  }

  observe(img, imageId) {
    img.dataset.imageId = String(imageId);
    this.observer.observe(img);
  }

  onVisible(entries) {
    for (const entry of entries) {
      if (!entry.isIntersecting) continue;
      const img = entry.target;
      this.observer.unobserve(img);
      thumbnailUrl(this.projectId, img.dataset.imageId)
        .then((url) => { img.src = url; })
        .catch(() => img.classList.add("missing"));
    }
  }
}
