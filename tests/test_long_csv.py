"""The vectorised CSV writer prints exactly what Python's ``%`` format prints, field by field."""

import numpy as np
import pytest

from bootnav.postproc.outputs import _csv_text, write_csv


def fields(x: np.ndarray, fmt: str) -> list[str]:
    """The fields of a one-column CSV text of ``x``."""
    return bytes(_csv_text([x], [fmt])).decode("ascii").splitlines()


# ties and near-ties of every decimal count, signed zeros, values rounding to -0, large, non-finite values
EDGES = np.array([0.0, -0.0, 5e-5, -5e-5, 4.9999e-5, 0.5, 1.5, 2.5, -2.5, 1.23455, 1.00005, 9.99995, 99999.99995,
                  86399.9999995, 1234567.0000005, 1e15, -1e16, 123456789012.3, np.nan, np.inf, -np.inf, 1e-300, -1e-7])


@pytest.mark.parametrize("fmt", ["%.0f", "%.3f", "%.4f", "%.5f", "%.6f"])
def test_every_field_equals_python_format(fmt):
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.normal(0, 10, 20_000), rng.normal(0, 1e-4, 5000), rng.uniform(0, 86_400, 5000),
                        np.round(rng.normal(0, 5, 5000) * 2e4) / 2e4,  # exact ties at the 5th decimal in decimal
                        np.round(rng.normal(0, 5, 5000), 7), EDGES])
    assert fields(x, fmt) == [fmt % v for v in x.tolist()]


def test_integer_columns():
    v = np.array([0, 1, -3, 255, 12, -1000000, 7], dtype=np.int64)
    assert fields(v, "%d") == [str(i) for i in v.tolist()]
    assert fields(np.array([True, False]), "%d") == ["1", "0"]
    assert fields(np.array([2.7, -2.7, 0.0]), "%d") == ["%d" % 2.7, "%d" % -2.7, "0"]
    with pytest.raises(ValueError, match="only %d and %.Nf"):
        _csv_text([v], ["%g"])


def test_file_equals_the_row_format(tmp_path, monkeypatch):
    """Several blocks of rows (block size made small), several columns: the same bytes as one ``%`` per row."""
    import bootnav.postproc.outputs as outputs

    monkeypatch.setattr(outputs, "_BLOCK_ROWS", 777)
    rng = np.random.default_rng(2)
    n = 5000
    cols = [np.cumsum(rng.uniform(0.004, 0.006, n)), *rng.normal(0, 3, (3, n)), rng.integers(0, 2, n)]
    for c in cols[1:4]:  # fields Python formats (ties, non-finite, huge) in several columns of the same rows
        c[rng.choice(n, EDGES.size, replace=False)] = EDGES
        c[4000 : 4000 + EDGES.size] = EDGES
    fmts = ["%.6f", "%.4f", "%.4f", "%.4f", "%d"]
    write_csv(tmp_path / "a.csv", ("t_s", "x", "y", "z", "stance"), cols, fmts)
    row = ",".join(fmts) + "\n"
    expected = "t_s,x,y,z,stance\n" + "".join(row % tuple(c[i] for c in cols) for i in range(n))
    assert (tmp_path / "a.csv").read_text() == expected
