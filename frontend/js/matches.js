// The matching panel: the images matched to the selected camera, with thumbnails and inlier
// counts; checked rows become manual deletions of the edit set ("delete selected matching").
// Paged (PAGE_SIZE rows, most inliers first): at 1,000 cameras a camera may have hundreds of
// partners, and every row fetches a thumbnail. The rows come from the version's pair list the
// editor already holds for its live preview; the API pages the same way (?order=inliers&limit=).
import { pairKey } from "./geometry.js";
import { thumbnailUrl } from "./thumbs.js";

export const PAGE_SIZE = 50;

export class MatchesPanel {
  constructor(root, { store, draft, editor }, signal) {
    Object.assign(this, { root, store, draft, editor });
    this.list = root.querySelector("#match-list");
    this.title = root.querySelector("#match-title");
    root.querySelector("#delete-matching").addEventListener("click", () => this.deleteChecked(true), { signal });
    root.querySelector("#keep-matching").addEventListener("click", () => this.deleteChecked(false), { signal });
    root.addEventListener("toggle", () => this.render(), { signal });
    this.pager = root.querySelector("#match-pager");
    this.range = root.querySelector("#match-range");
    this.page = 0;
    this.pageOf = null; // the camera the page number belongs to
    root.querySelector("#match-prev").addEventListener("click", () => this.turn(-1), { signal });
    root.querySelector("#match-next").addEventListener("click", () => this.turn(1), { signal });
  }

  turn(step) {
    this.page = Math.max(0, this.page + step);
    this.render();
  }

  get focusId() {
    const { selection, anchor } = this.store;
    if (selection.has(anchor)) return anchor;
    return selection.size ? [...selection][0] : null;
  }

  render() {
    if (!this.root.open) return; // rebuilt when opened; not on every key press while closed
    const id = this.focusId;
    const cam = this.store.byId.get(id);
    this.list.replaceChildren();
    if (!cam) {
      this.title.textContent = "Select a camera to list its matched images.";
      this.pager.hidden = true;
      return;
    }
    const partners = [...(this.store.pairs.get(id) ?? [])].sort((a, b) => b[1] - a[1] || a[0] - b[0]);
    if (this.pageOf !== id) [this.page, this.pageOf] = [0, id];
    const pages = Math.max(1, Math.ceil(partners.length / PAGE_SIZE));
    this.page = Math.min(this.page, pages - 1);
    const first = this.page * PAGE_SIZE;
    const shown = partners.slice(first, first + PAGE_SIZE);
    this.title.textContent = `${cam.name}: ${partners.length} matched images`;
    this.root.dataset.imageId = String(id);
    for (const [partner, inliers] of shown) this.list.append(this.row(id, partner, inliers));
    this.showPager(first, shown.length, partners.length, pages);
  }

  showPager(first, count, total, pages) {
    this.pager.hidden = pages < 2;
    this.range.textContent = count ? `${first + 1}-${first + count} of ${total}` : "";
    this.pager.querySelector("#match-prev").disabled = this.page === 0;
    this.pager.querySelector("#match-next").disabled = this.page >= pages - 1;
  }

  row(id, partner, inliers) {
    const other = this.store.byId.get(partner);
    const key = pairKey(id, partner);
    const li = document.createElement("li");
    li.dataset.pair = key;
    li.classList.toggle("deleted", this.draft.deletePairs.has(key));
    const label = document.createElement("label");
    const box = document.createElement("input");
    box.type = "checkbox";
    box.value = key;
    box.disabled = !this.store.canWrite; // it only picks pairs for deletion
    const img = document.createElement("img");
    img.alt = "";
    thumbnailUrl(this.store.project.id, partner).then((url) => { img.src = url; }, () => {});
    const text = document.createElement("span");
    const state = this.draft.deletePairs.has(key) ? " (deleted)" : "";
    text.textContent = `${other?.name ?? partner}: ${inliers} inliers${state}`;
    label.append(box, img, text);
    li.append(label);
    const hover = (id) => { this.store.hovered = id; this.store.emit("hover"); };
    li.addEventListener("pointerenter", () => hover(partner));
    li.addEventListener("pointerleave", () => hover(null));
    return li;
  }

  deleteChecked(deleted) {
    const keys = [...this.list.querySelectorAll("input:checked")].map((box) => box.value);
    if (!keys.length || !this.editor.canEdit()) return;
    this.draft.change((d) => d.togglePairs(keys, deleted));
  }
}
