"""The printed report of ``object_transfer.py``: how it ran, one table per score (rows: the
image-blind baseline and each training set; columns: the test domains; cells: mean ± standard
error over the training seeds), then what the frames and the trainings cost."""

from __future__ import annotations

from dr_transfer.object_domains import SET_LABELS, TEST_DOMAINS
from dr_transfer.scoring import shown

SCORES = {  # score -> table title
    "object": "IoU of object (%)",
    "object_vs_rest": "object vs rest IoU (%)",
    "instance_recall": "instance recall at IoU 0.5 (%)",
    "other": "IoU of other (%)",
    "table": "IoU of table (%)",
    "tray": "IoU of tray (%)",
}
BLIND = "image-blind (prior)"
ROW, CELL = 32, 14  # characters


def report(result: dict) -> str:
    lines = [
        f"command: {result['command']}",
        f"commit:  {result['commit']}",
        f"machine: {result['cpu']['line']}; {result['threads']} torch threads, device "
        f"{result['device']}, precision {result['precision']['precision']} "
        f"({result['precision']['why']})",
        f"net:     {result['net']['name']} ({result['net']['why']}), trained from scratch, "
        f"{result['epochs']} epochs; frames {result['size'][0]}x{result['size'][1]} "
        "of the wrist camera",
        f"mean ± standard error over training seeds {result['seeds']}; {BLIND}: each pixel's "
        "most common class in the default training set (no seed: ± 0.0)",
        "object vs rest: the mean of the IoUs of object and of not-object; instance recall: "
        "the share of target instances that one connected region of predicted object "
        "overlaps with IoU >= 0.5",
        "test domains: " + ", ".join(f"{d}: {label}" for d, label in TEST_DOMAINS.items()),
    ]
    for score, title in SCORES.items():
        lines += ["", f"{title:{ROW}}" + "".join(f"{d:>{CELL}}" for d in TEST_DOMAINS)]
        lines.append(_row(BLIND, result["blind"], score))
        lines += [_row(SET_LABELS[n], s["scores"], score) for n, s in result["sets"].items()]
    return "\n".join([*lines, "", *_costs(result)])


def _row(label: str, scores: dict, score: str) -> str:
    cells = []
    for domain in TEST_DOMAINS:
        runs = scores.get(domain)
        cells.append(shown([r[score] for r in runs]) if runs else "—")
    return f"{label:{ROW}}" + "".join(f"{c:>{CELL}}" for c in cells)


def _costs(result: dict) -> list[str]:
    """Frames and instances of each test domain, then what each set cost to build and train."""
    domains = result["domains"].items()
    counts = ", ".join(f"{d} {v['frames']} frames, {v['instances']} targets" for d, v in domains)
    lines = [f"test domains: {counts}", "cost of each set:"]
    for name, built in [*domains, *result["sets"].items()]:
        cost = "read from --out"
        if built.get("build_s"):
            cost = f"built in {built['build_s']:.0f} s: first frame {built['first_sample_s']:.0f} s"
            if built.get("steady_s_per_frame"):
                cost += f", then {built['steady_s_per_frame']:.2f} s/frame"
        if "train_s_per_epoch" in built:
            cost += f"; trained {built['train_s_per_epoch']:.2f} s/epoch"
        if built.get("commit", result["commit"]) != result["commit"]:
            cost += f" at {built['commit']} (an earlier run of this recipe)"
        label = SET_LABELS.get(name, name)
        lines.append(f"  {label:{ROW - 2}}{built['frames']:6} frames, {cost}")
    return lines
