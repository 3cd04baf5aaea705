"""docs/python.md's worked example runs as written: its ```python blocks,
in order, in one namespace (plotting blocks, which start with `# plot`,
only where matplotlib is installed)."""

import re


def python_blocks(text):
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_docs_python_md_example_runs(repo, tmp_path, monkeypatch):
    blocks = python_blocks((repo / "docs/python.md").read_text())
    assert len(blocks) >= 3
    # The example's paths are relative to a checkout.
    (tmp_path / "sims").symlink_to(repo / "sims")
    monkeypatch.chdir(tmp_path)
    try:
        import matplotlib

        matplotlib.use("Agg")
        have_plot = True
    except ImportError:
        have_plot = False
    ns = {"__name__": "__main__"}
    ran = 0
    for code in blocks:
        if code.startswith("# plot") and not have_plot:
            continue
        exec(compile(code, "docs/python.md", "exec"), ns)
        ran += 1
    assert ran >= 3
    # What the example states it computes.
    assert ns["result"].radiance.ndim == 3
    assert sorted(ns["captures"]) == [20, 100, 500]
    means = [ns["captures"][g].frames.mean() for g in (20, 100, 500)]
    assert means[0] < means[1] < means[2], means
    if have_plot:
        assert (tmp_path / "office-gen3-histograms.png").stat().st_size > 0
