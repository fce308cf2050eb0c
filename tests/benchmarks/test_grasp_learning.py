"""benchmarks/grasp_learning_report.py: what the table of benchmarks/grasp_learning.py says
bounds the learned sampler (it chooses among the antipodal sampler's candidates), from recorded
outcomes; and its learning curves drawn in both domains."""

from __future__ import annotations

import pytest


@pytest.fixture
def report(benchmark_module):
    return benchmark_module("grasp_learning_report")


def test_the_learned_sampler_is_bounded_by_the_attempts_with_a_candidate(report):
    # 10 attempts: the antipodal sampler found a candidate in the first 6 and held 3 of them
    antipodal = {
        "success": [True, True, True, False, False, False, False, False, False, False],
        "found": [True] * 6 + [False] * 4,
    }
    learned = {"success": [True] * 5 + [False] * 5, "found": [True] * 6 + [False] * 4}
    lines = report.coverage_lines("panda", "objects", {"antipodal": antipodal, "l": learned})
    # at most 6 of 10 held: 60 % against antipodal's 30 %
    assert lines[0] == (
        "panda objects: a candidate in 6 of 10 attempts, so learned - antipodal is at most "
        "+30.0; on those 6:"
    )
    assert lines[1].split() == ["antipodal", "50.0", "±", "20.4"]
    assert lines[2].split() == ["l", "83.3", "±", "15.2"]


def test_runs_kept_before_coverage_was_recorded_print_no_bound(report):
    runs = {"antipodal": {"success": [True, False]}, "l": {"success": [True, True]}}
    assert report.coverage_lines("panda", "scenes", runs) == []


def test_the_reach_line_counts_unreachable_attempts_and_how_far_their_targets_were(report):
    run = {
        "success": [True, True, False, False, False],
        "modes": [None, None, "unreachable", "unreachable", "slipped"],
        "reach_m": [0.6, 0.7, 0.8, 0.9, 0.5],
        "ik_failed": [False, False, True, False, False],
    }
    lines = report.reach_lines("panda", "objects", {"antipodal": run})
    assert lines == [
        "panda objects antipodal: unreachable 2 (IK failed 1), targets a median 0.85 m from "
        "the base; successes 0.65 m"
    ]
    assert report.reach_lines("panda", "scenes", {"antipodal": {"success": []}}) == []


def test_each_target_class_gets_its_own_line_with_the_largest_model(report):
    classes = ["lemon", "can", "lemon", "can", "can"]
    runs = {
        "antipodal": {"success": [False, True, False, True, False], "classes": classes},
        "antipodal-reach": {"success": [True, True, False, True, True]},
        "learned-250": {"success": [True] * 5},  # not the largest: left out
        "learned-1000": {"success": [True, True, True, False, False]},
    }
    assert report.class_lines("panda", "objects", runs) == [
        "panda objects per target class, success %: antipodal, antipodal-reach, learned-1000",
        "  can          (n   3):  66.7 ± 27.2, 100.0 ±  0.0,  33.3 ± 27.2",
        "  lemon        (n   2):   0.0 ±  0.0,  50.0 ± 35.4, 100.0 ±  0.0",
    ]
    del runs["antipodal"]["classes"]  # kept by a run before classes were recorded
    assert report.class_lines("panda", "objects", runs) == []


def test_the_learning_curves_are_drawn_for_every_arm_and_domain(report, tmp_path):
    def run(success):
        return {"success": success}

    runs = {
        "antipodal": run([True, False]),
        "learned-250": run([True, False]),
        "learned-1000": run([True, True]),
        "antipodal-reach": run([True, True]),
        "learned-250-reach": run([True, True]),
        "learned-1000-reach": run([True, True]),
    }
    result = {"arms": {"panda": {"domains": {"scenes": runs, "objects": runs}}}}
    report.draw(result, tmp_path / "curve.png")
    import PIL.Image

    with PIL.Image.open(tmp_path / "curve.png") as picture:
        assert picture.size[0] > 2 * picture.size[1]  # two panels side by side


def test_the_curve_line_gives_each_size_and_the_paired_gain_of_the_largest(report):
    runs = {
        "antipodal": {"success": [False] * 4},
        "learned-1000": {"success": [True, True, True, False]},
        "learned-250": {"success": [True, False, False, False]},
        "learned-250-reach": {"success": [True, True, False, False]},
    }
    (line,) = report.curve_lines("panda", "scenes", runs)  # no curve with one reach-checked size
    assert line == (
        "panda scenes learning curve, 250, 1000 attempts: 25.0 -> 75.0 %; 1000 - 250: +50.0 ± 28.9 "
        "(paired)"
    )


def test_a_longer_curve_adds_training_campaigns_and_keeps_the_first_name(benchmark_module):
    grasp_learning = benchmark_module("grasp_learning")
    names = [grasp_learning.training_name("panda", 2000, seed) for seed in range(3)]
    assert names == ["panda-train-2000", "panda-train-2000-seed1", "panda-train-2000-seed2"]


def test_a_curve_size_past_one_campaign_must_fill_whole_campaigns(
    benchmark_module, monkeypatch, capsys
):
    grasp_learning = benchmark_module("grasp_learning")
    monkeypatch.setattr("sys.argv", ["grasp_learning.py", "--curve", "250", "2000", "4000"])
    assert grasp_learning.arguments().chunk == 2000
    monkeypatch.setattr("sys.argv", ["grasp_learning.py", "--curve", "250", "2000", "3000"])
    with pytest.raises(SystemExit):
        grasp_learning.arguments()
    assert "--curve [3000]: sizes above 2000 must be multiples of it" in capsys.readouterr().err


def test_models_of_several_grasps_a_scene_get_their_own_label_curve_and_paired_line(report):
    assert report.learned_label(1000) == "learned-1000"
    assert report.learned_label(1000, 4) == "learned-1000x4"
    held = {"success": [True, True, False, False]}
    runs = {
        "antipodal": {"success": [False] * 4},
        "learned-250": {"success": [True, False, False, False]},
        "learned-1000": held,
        "learned-250x4": {"success": [True, True, True, False]},
        "learned-1000x4": {"success": [True] * 4},
        "learned-1000x4-reach": {"success": [True] * 4},
    }
    assert report.learned_models(runs) == {1: [250, 1000], 4: [250, 1000]}
    assert list(report.learned_models(runs)) == [1, 4]
    curves = report.curve_lines("iiwa14", "objects", runs)
    assert [line.split(",")[0] for line in curves] == [
        "iiwa14 objects learning curve",
        "iiwa14 objects learning curve (4 grasps a scene)",
    ]
    assert report.per_scene_lines("iiwa14", "objects", runs) == [
        "iiwa14 objects 250 training attempts, 4 grasps a scene against one: 75.0 against "
        "25.0 %, +50.0 ± 28.9 (paired)",
        "iiwa14 objects 1000 training attempts, 4 grasps a scene against one: 100.0 against "
        "50.0 %, +50.0 ± 28.9 (paired)",
    ]


def test_training_campaigns_of_several_grasps_a_scene_are_named_apart(benchmark_module):
    grasp_learning = benchmark_module("grasp_learning")
    assert grasp_learning.training_name("iiwa14", 1000, 0, 4) == "iiwa14-train-1000-x4"
    assert grasp_learning.training_name("iiwa14", 1000, 1, 4) == "iiwa14-train-1000-x4-seed1"
