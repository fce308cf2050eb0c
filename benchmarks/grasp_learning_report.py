"""What ``benchmarks/grasp_learning.py`` prints and draws from its results: success rates with
their binomial standard errors, paired gains over the same attempts, what bounds the learned
sampler (the attempts where the antipodal sampler found a candidate), where the arm could not
go, each model's scores, and the learning curves in both domains."""

from __future__ import annotations

import math
import re
import statistics
from collections import defaultdict
from pathlib import Path

REACH = "-reach"  # a sampler's label with campaign.check_reach on
# the learned sampler with a model of N training attempts, "xK" where its training campaigns
# executed K grasps a scene (campaign.grasps_per_scene)
LEARNED = re.compile(r"learned-(\d+)(?:x(\d+))?")


def model_label(attempts: int, per_scene: int = 1) -> str:
    """A model trained on ``attempts`` of ``per_scene`` grasps a scene: ``1000``, ``1000x4``."""
    return f"{attempts}" + (f"x{per_scene}" if per_scene > 1 else "")


def learned_label(attempts: int, per_scene: int = 1) -> str:
    """The learned sampler's label with that model."""
    return f"learned-{model_label(attempts, per_scene)}"


def rate(success: list[bool]) -> tuple[float, float]:
    """Success rate and its binomial standard error, in percent."""
    n = len(success)
    p = sum(success) / n
    return 100 * p, 100 * math.sqrt(p * (1 - p) / n)


def paired_gain(learned: list[bool], antipodal: list[bool]) -> tuple[float, float]:
    """Mean of learned - antipodal over the same attempts, and its standard error, in points."""
    diff = [int(a) - int(b) for a, b in zip(learned, antipodal, strict=True)]
    se = statistics.stdev(diff) / math.sqrt(len(diff)) if len(diff) > 1 else float("nan")
    return 100 * statistics.fmean(diff), 100 * se


def table(result: dict) -> str:
    lines = [
        f"{result['cpu']}; {result['command']}; commit {result['commit']}",
        "arm     domain   sampler             success %        - antipodal     "
        "- antipodal-reach  attempts/s  failures",
    ]
    for arm, arm_result in result["arms"].items():
        for domain, runs in arm_result["domains"].items():
            for sampler, run in runs.items():
                p, se = rate(run["success"])
                gains = []
                for base in ("antipodal", f"antipodal{REACH}"):
                    paired = sampler != base and base in runs
                    paired &= base == "antipodal" or (sampler.endswith(REACH))
                    g, gse = (
                        paired_gain(run["success"], runs[base]["success"]) if paired else (0, 0)
                    )
                    gains.append(f"{g:+6.1f} ± {gse:4.1f}" if paired else "")
                speed = run["attempts_per_s"]
                lines.append(
                    f"{arm:7} {domain:8} {sampler:19} {p:5.1f} ± {se:4.1f} (n {len(run['success'])})"
                    f"  {gains[0]:15} {gains[1]:16}  {speed if speed is not None else '-':>10}  "
                    f"{run['failure_modes']}"
                )
        for domain, runs in arm_result["domains"].items():
            lines += curve_lines(arm, domain, runs) + per_scene_lines(arm, domain, runs)
            lines += coverage_lines(arm, domain, runs) + reach_lines(arm, domain, runs)
            lines += class_lines(arm, domain, runs)
        lines.append(f"{arm} models (held-out training attempts):")
        for n, m in arm_result["models"].items():
            within = (m.get("within_scene") or {}).get("roc_auc")
            lines.append(
                f"  {n:>7} attempts: {m['examples']} examples, accuracy {m['accuracy']}, "
                f"ROC AUC {m['roc_auc']}, calibration error {m['ece']}, trained in {m['train_s']} s"
                + (f"; within one scene {within}" if within is not None else "")
            )
            for domain, auc in m.get("transfer", {}).items():
                every, reached = (
                    f"{a['roc_auc']:.3f} (n {a['n']})" if a["roc_auc"] is not None else "-"
                    for a in (auc["all"], auc["reached"])
                )
                lines.append(
                    f"    ROC AUC on the antipodal sampler's {domain} grasps: {every}, "
                    f"reached only {reached}"
                )
    return "\n".join(lines)


def learned_models(runs: dict) -> dict[int, list[int]]:
    """Per grasps a scene of their training campaigns, in order, the training attempts of the
    models whose learned sampler ran (``learned-N``, ``learned-NxK``), in order."""
    sizes: dict[int, set[int]] = defaultdict(set)
    for sampler in runs:
        if found := LEARNED.fullmatch(sampler.removesuffix(REACH)):
            sizes[int(found[2] or 1)].add(int(found[1]))
    return {k: sorted(sizes[k]) for k in sorted(sizes)}


def curve_lines(arm: str, domain: str, runs: dict) -> list[str]:
    """The learning curve in one domain, with and without the reach check: success of each
    model size, and largest - smallest paired over the same attempts."""
    lines = []
    for k, sizes in learned_models(runs).items():
        trained = f" ({k} grasps a scene)" if k > 1 else ""
        for suffix in ("", REACH):
            names = [learned_label(n, k) + suffix for n in sizes]
            if len(names) < 2 or any(name not in runs for name in names):
                continue
            rates = " -> ".join(f"{rate(runs[name]['success'])[0]:.1f}" for name in names)
            gain, se = paired_gain(runs[names[-1]]["success"], runs[names[0]]["success"])
            lines.append(
                f"{arm} {domain} learning curve{suffix}{trained}, "
                f"{', '.join(map(str, sizes))} attempts: {rates} %; "
                f"{sizes[-1]} - {sizes[0]}: {gain:+.1f} ± {se:.1f} (paired)"
            )
    return lines


def per_scene_lines(arm: str, domain: str, runs: dict) -> list[str]:
    """Models trained on as many attempts of K grasps a scene against one a scene: success
    of each and the paired difference over the same attempts, with and without the check."""
    lines = []
    models = learned_models(runs)
    one_a_scene = set(models.get(1, []))
    for k, sizes in models.items():
        for n in sorted(set(sizes) & one_a_scene) if k > 1 else []:
            for suffix in ("", REACH):
                many, one = learned_label(n, k) + suffix, learned_label(n) + suffix
                if many not in runs or one not in runs:
                    continue
                gain, se = paired_gain(runs[many]["success"], runs[one]["success"])
                lines.append(
                    f"{arm} {domain} {n} training attempts, {k} grasps a scene against one"
                    f"{suffix}: {rate(runs[many]['success'])[0]:.1f} against "
                    f"{rate(runs[one]['success'])[0]:.1f} %, {gain:+.1f} ± {se:.1f} (paired)"
                )
    return lines


def coverage_lines(arm: str, domain: str, runs: dict) -> list[str]:
    """What bounds the learned sampler in one domain: it chooses among the antipodal sampler's
    candidates, so it succeeds at most where that sampler found one; and how the two samplers
    do on the attempts where it did."""
    base = runs["antipodal"]
    if "found" not in base:  # kept by a run before this was recorded
        return []
    found = [i for i, ok in enumerate(base["found"]) if ok]
    n = len(base["found"])
    ceiling = 100 * len(found) / n - rate(base["success"])[0]
    lines = [
        f"{arm} {domain}: a candidate in {len(found)} of {n} attempts, so learned - antipodal "
        f"is at most {ceiling:+.1f}; on those {len(found)}:"
    ]
    for sampler, run in runs.items():
        p, se = rate([run["success"][i] for i in found]) if found else (float("nan"), 0.0)
        lines.append(f"  {sampler:19} {p:5.1f} ± {se:4.1f}")
    return lines


def reach_lines(arm: str, domain: str, runs: dict) -> list[str]:
    """Where the arm could not go: per sampler, its ``unreachable`` attempts (those with no IK
    solution for the pre-grasp pose among them) and the median distance from the base to their
    targets, against that of its successes."""
    lines = []
    for sampler, run in runs.items():
        if "reach_m" not in run:  # kept by a run before this was recorded
            continue
        modes = [
            None if ok else mode for ok, mode in zip(run["success"], run["modes"], strict=True)
        ]
        far = [r for r, m in zip(run["reach_m"], modes, strict=True) if m == "unreachable"]
        near = [r for r, ok in zip(run["reach_m"], run["success"], strict=True) if ok]
        ik = sum(run["ik_failed"])
        lines.append(
            f"{arm} {domain} {sampler}: unreachable {len(far)} (IK failed {ik}), targets a median "
            f"{statistics.median(far) if far else float('nan'):.2f} m from the base; "
            f"successes {statistics.median(near) if near else float('nan'):.2f} m"
        )
    return lines


def class_lines(arm: str, domain: str, runs: dict) -> list[str]:
    """Success per target class (the classes differ in size, and a mean over the easy ones can
    hide the one that matters): the antipodal sampler and the largest model, each with and
    without the check, on the attempts whose target is of that class."""
    if "classes" not in runs["antipodal"]:  # kept by a run before this was recorded
        return []
    classes = runs["antipodal"]["classes"]
    largest = [learned_label(sizes[-1], k) for k, sizes in learned_models(runs).items()]
    samplers = [s for b in ("antipodal", *largest) for s in (b, b + REACH) if s in runs]
    lines = [f"{arm} {domain} per target class, success %: " + ", ".join(samplers)]
    for name in sorted(set(classes)):
        rows = [i for i, c in enumerate(classes) if c == name]
        rates = (rate([runs[s]["success"][i] for i in rows]) for s in samplers)
        cells = ", ".join(f"{p:5.1f} ± {se:4.1f}" for p, se in rates)
        lines.append(f"  {name:12} (n {len(rows):3}): {cells}")
    return lines


def draw(result: dict, path: Path) -> None:
    """The learning curves: per arm and domain, the learned sampler's success against its
    training attempts, with and without the reach check, over the antipodal sampler's bands."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    arms = list(result["arms"])
    domains = list(dict.fromkeys(d for r in result["arms"].values() for d in r["domains"]))
    figure, axes = plt.subplots(
        len(arms), len(domains), figsize=(5 * len(domains), 3.6 * len(arms)), squeeze=False
    )
    for ax, (arm, domain) in zip(
        axes.flat, [(arm, d) for arm in arms for d in domains], strict=True
    ):
        if domain not in result["arms"][arm]["domains"]:
            ax.set_axis_off()
            continue
        runs = result["arms"][arm]["domains"][domain]
        models = learned_models(runs)
        ticks = sorted({n for sizes in models.values() for n in sizes})
        for k, sizes in models.items():
            for suffix, label in (("", "learned"), (REACH, "learned, reach checked")):
                if f"{learned_label(sizes[0], k)}{suffix}" not in runs:
                    continue
                rates = [rate(runs[learned_label(n, k) + suffix]["success"]) for n in sizes]
                label += f", {k} grasps a scene" if k > 1 else ""
                ax.errorbar(
                    sizes, [r[0] for r in rates], [r[1] for r in rates], marker="o", label=label
                )
        for sampler, colour in (("antipodal", "grey"), (f"antipodal{REACH}", "tan")):
            if sampler in runs:
                base, se = rate(runs[sampler]["success"])
                ax.axhspan(base - se, base + se, color=colour, alpha=0.3, label=f"{sampler} ± SE")
        ax.set(title=f"{arm}, held-out {domain}", xlabel="training attempts", ylabel="success %")
        ax.set_xscale("log")
        ax.set_xticks(ticks, [str(n) for n in ticks])
        ax.minorticks_off()
        ax.legend(fontsize="small")
    figure.tight_layout()
    figure.savefig(path, dpi=80)
    plt.close(figure)


if __name__ == "__main__":  # a helper of grasp_learning.py: only --help here
    import argparse

    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
