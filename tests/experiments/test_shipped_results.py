"""The shipped report runs (``otgym/data/results``) and the demo report's paragraphs on them."""

import json

import pytest

from otgym.experiments.demo import shipped_results as sr

SUMMARY_HEADER = (
    "mode,trials,participants,success_mean,success_sd,obstacles_encountered,obstacles_avoided,avoided_rate,"
    "avoided_rate_ci_low,avoided_rate_ci_high,goals_reached,goal_rate,goal_rate_ci_low,goal_rate_ci_high,"
    "completion_time_mean_s,completion_time_sd_s,trap_losses,detachments"
)


def write_run(folder, *, with_command=True):
    folder.mkdir()
    (folder / "summary.csv").write_text(
        SUMMARY_HEADER + "\n"
        "manual,64,8,0.945,0.12,203,191,0.9409,0.8995,0.9659,58,0.906,0.81,0.956,150.8,12.5,6,16\n"
        "shared,64,8,0.927,0.05,231,214,0.9264,0.8853,0.9535,61,0.953,0.87,0.98,78.4,1.0,3,0\n"
        "autonomous,64,8,0.548,0.0,0,0,,,,64,1.0,0.94,1.0,60.7,0.0,0,0\n"
    )
    (folder / "acceptance.json").write_text(
        json.dumps(
            {
                "(b) manual time >= 1.8x shared time": True,
                "(d) shared avoids at least as many as manual": False,
                "route_bound_s": 72.5,
                "seed": 7500,
                "seed_status": "report seed",
            }
        )
    )
    (folder / "stats.json").write_text(
        json.dumps(
            {
                "success": {
                    "metric": "success",
                    "n_participants": 8,
                    "anova": {"F": 310.0, "ddof1": 2, "ddof2": 14, "p": 1e-10, "eps": 0.6},
                    "posthoc": [
                        {"a": "manual", "b": "shared", "T": 1.21, "dof": 7.0, "p_unc": 0.27, "p_holm": 0.27},
                        {"a": "autonomous", "b": "shared", "T": -95.8, "dof": 7.0, "p_unc": 4e-12, "p_holm": 1.1e-11},
                    ],
                },
                "time": {"metric": "time", "n_participants": 8, "anova": {"F": None}, "posthoc": []},
            }
        )
    )
    if with_command:
        (folder / "command.txt").write_text("otgym experiment shared-control --out DIR\n")


def test_a_run_folder_becomes_a_fig8_run_and_its_paragraph_quotes_every_figure(tmp_path):
    """Counts, intervals, goals, the seed's status and each item (passed or missed) reach
    the text; an item that failed is not printed as passed, and a mode with no obstacle
    met prints '-' rather than a rate."""
    write_run(tmp_path / "route")
    run = sr.collect_fig8_run("route autonomy", tmp_path / "route")
    assert run["seed"] == 7500 and run["route_bound_s"] == 72.5
    assert run["items"] == {
        "(b) manual time >= 1.8x shared time": True,
        "(d) shared avoids at least as many as manual": False,
    }
    text = "\n".join(sr.fig8_lines({"runs": [run]}))
    assert "held-out seed 7500, 8 participants x 8 trials per mode" in text
    assert "| manual | 191 / 203 = 94.1 % [90.0, 96.6] | 94.5 ± 12.0 % | 58 of 64 | 150.8 ± 12.5 | 6 |" in text
    assert "| autonomous | - |" in text
    assert "- passes: (b) manual time >= 1.8x shared time (manual 150.8 s against shared 78.4 s: 1.92x)" in text
    assert (
        "- **misses**: (d) shared avoids at least as many as manual "
        "(shared 92.7 % against manual 94.5 %, paired t(7) = 1.21, Holm p = 0.27)" in text
    )
    assert run["tests"]["success"]["pairs"][0]["p_holm"] == 0.27  # the p-values travel into fig8.json
    assert run["tests"]["success"]["anova"] == {"F": 310.0, "ddof1": 2, "ddof2": 14, "p": 1e-10}
    run["seed_status"] = "development seed"
    assert "development seed 7500" in "\n".join(sr.fig8_lines({"runs": [run]}))
    assert sr.fig8_lines(None) == [] and sr.fig8_lines({"runs": []}) == []


def test_an_item_d_that_passes_without_significance_is_not_printed_as_a_bare_pass(tmp_path):
    """(d) passed on point estimates with Holm p = 0.27: the line gives the statistic and
    says the difference is not significant; a significant one reads as a plain pass, and
    a run without recorded tests says (d) was not tested."""
    write_run(tmp_path / "route")
    run = sr.collect_fig8_run("route autonomy", tmp_path / "route")
    run["items"] = {"(d) shared avoids at least as many as manual": True}
    text = "\n".join(sr.fig8_lines({"runs": [run]}))
    assert "- passes: (d)" not in text
    assert (
        "- passes on point estimates only; the difference is **not significant**: (d) shared avoids at least "
        "as many as manual (shared 92.7 % against manual 94.5 %, paired t(7) = 1.21, Holm p = 0.27)" in text
    )
    run["tests"]["success"]["pairs"][0]["p_holm"] = 0.01
    assert "- passes: (d) shared avoids at least as many as manual (" in "\n".join(sr.fig8_lines({"runs": [run]}))
    run["tests"] = None
    text = "\n".join(sr.fig8_lines({"runs": [run]}))
    assert "passes on point estimates only; **not tested**: (d)" in text and "no paired test recorded" in text


def test_the_shipped_fig8_gives_item_d_its_p_value():
    """The shipped report run of the route follower carries (d)'s Holm p (0.27) and the
    demo's report says it is not significant."""
    fig8 = sr.shipped_fig8()
    route = fig8["runs"][0]
    assert route["items"]["(d) shared avoids at least as many as manual"] is True
    text = "\n".join(sr.fig8_lines(fig8))
    assert "Holm p = 0.27)" in text and "**not significant**: (d)" in text


def test_a_folder_without_its_command_is_refused_by_name(tmp_path, capsys):
    """By the collector, and by ``otgym experiment fig8-json`` (one error line naming the
    missing file, exit 2, nothing written), as is a call that gives no run."""
    from otgym.cli import app as cli_app

    write_run(tmp_path / "run", with_command=False)
    with pytest.raises(FileNotFoundError, match="command.txt"):
        sr.collect_fig8_run("x", tmp_path / "run")
    for runs, word in (([f"x={tmp_path / 'run'}"], "command.txt"), ([], "LABEL=DIR")):
        with pytest.raises(SystemExit) as exit_info:
            cli_app.main(["experiment", "fig8-json", "--out", str(tmp_path / "out.json"), *runs])
        lines = capsys.readouterr().err.strip().splitlines()
        assert exit_info.value.code == 2 and len(lines) == 1 and lines[0].startswith("error: "), lines
        assert word in lines[0] and not (tmp_path / "out.json").exists()


def test_the_shipped_files_are_report_runs_on_held_out_seeds():
    """What the demo quotes: the front of the shipped policy (1,024 held-out episodes) and,
    where shipped, the Fig. 8 runs, each on a seed listed as a report seed."""
    from otgym.experiments.common.seeds import DEVELOPMENT, REPORT_SEEDS

    front = sr.shipped_front()
    assert front is not None and front["seed_status"] == "held out" and front["episodes"] >= 1024
    assert front["seed"] == REPORT_SEEDS["speed-front"]
    text = "\n".join(sr.front_lines(front))
    assert f"held-out seed {front['seed']}, {front['episodes']} episodes" in text
    fig8 = sr.shipped_fig8()
    if fig8 is not None:
        for run in fig8["runs"]:
            # a report run on today's report seed, or on one retired since (the model changed after
            # its run; the seed registry names it and its successor, and the old result stays shipped)
            retired = any(
                use.space == "study"
                and use.first <= run["seed"] <= use.last
                and "next report uses seed" in use.used_for
                for use in DEVELOPMENT
            )
            assert run["seed_status"] == "report seed"
            assert run["seed"] == REPORT_SEEDS["shared-control"] or retired, run["seed"]
            assert all(mode["participants"] == 8 and mode["trials"] >= 64 for mode in run["modes"])
