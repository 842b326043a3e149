"""CSV replay: columns by name with aliases, host times kept or stamped, pacing options,
damaged rows skipped and counted, clear errors for missing files and columns."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from spectratac.ft import FTConfigError, FTError, FTNotFoundError, FTURLError, open_ft


def write(path: Path, header: str, rows: list[str]) -> str:
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return f"csv://{path}"


def test_columns_in_any_order_with_aliases(tmp_path: Path) -> None:
    url = write(
        tmp_path / "a.csv",
        "Mz,My,Mx,Fz,Fy,Fx,sensor_time,status",
        [f"6,5,4,3,2,1,{i / 100},{i % 2}" for i in range(10)],
    )
    with open_ft(url) as ft:
        rows = ft.read(100, timeout=1.0)
        assert ft.info.rate_hz == pytest.approx(100.0)
    assert len(rows) == 10
    assert rows["wrench"][0].tolist() == [1, 2, 3, 4, 5, 6]
    assert rows["status"].tolist() == [0, 1] * 5
    assert rows["sequence"].tolist() == list(range(10))
    assert np.all(np.isfinite(rows["host_time"]))  # stamped on arrival (no host_time column)


def test_host_time_column_is_kept_or_replaced(tmp_path: Path) -> None:
    url = write(tmp_path / "h.csv", "t,Fx,Fy,Fz,Tx,Ty,Tz,host_time", ["0,0,0,0,0,0,0,123.5"])
    with open_ft(url) as ft:
        assert ft.read(1, timeout=1.0)["host_time"][0] == 123.5
    with open_ft(url + "?host_time=now") as ft:
        assert ft.read(1, timeout=1.0)["host_time"][0] != 123.5
    bare = write(tmp_path / "b.csv", "t,Fx,Fy,Fz,Tx,Ty,Tz", ["0,0,0,0,0,0,0"])
    with pytest.raises(FTConfigError, match="host_time=now"):
        open_ft(bare + "?host_time=file")


def test_damaged_rows_and_sequence_gaps_are_counted(tmp_path: Path) -> None:
    url = write(
        tmp_path / "d.csv",
        "t,Fx,Fy,Fz,Tx,Ty,Tz,sequence",
        [
            "0,1,1,1,1,1,1,0",
            "0.001,1,1,oops,1,1,1,1",
            "0.002,1,1,1,1,1",
            "0.003,1,1,1,nan,1,1,3",
            "0.004,1,1,1,1,1,1,4",
            "0.007,1,1,1,1,1,1,7",
        ],
    )
    with open_ft(url) as ft:
        rows = ft.read(100, timeout=1.0)
    assert rows["sequence"].tolist() == [0, 4, 7]
    assert ft.stats.bad_frames == 3 and ft.stats.lost == 5 and ft.stats.gaps == 2


def test_paced_replay_releases_rows_gradually(tmp_path: Path) -> None:
    url = write(tmp_path / "p.csv", "t,Fx,Fy,Fz,Tx,Ty,Tz", [f"{i},0,0,0,0,0,0" for i in range(50)])
    with open_ft(url + "?realtime=1") as ft:  # one row per second: most are still to come
        first = ft.read(50, timeout=0.2)
    assert 1 <= len(first) < 50
    with open_ft(url + "?rate=100000") as ft:
        assert len(ft.read(50, timeout=5.0)) == 50
    with open_ft(url) as ft:  # as fast as possible, then the end
        assert len(ft.read(10**6, timeout=5.0)) == 50
        assert list(ft) == []


def test_iteration_yields_every_row_then_stops(tmp_path: Path) -> None:
    url = write(tmp_path / "i.csv", "t,Fx,Fy,Fz,Tx,Ty,Tz", [f"{i},{i},0,0,0,0,0" for i in range(7)])
    with open_ft(url) as ft:
        assert [float(r["wrench"][0]) for r in ft] == [0, 1, 2, 3, 4, 5, 6]


def test_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(FTNotFoundError, match="no such F/T CSV file"):
        open_ft(f"csv://{tmp_path}/missing.csv")
    url = write(tmp_path / "c.csv", "t,Fx,Fy", ["0,0,0"])
    with pytest.raises(FTConfigError, match=r"lacks column.*Fz"):
        open_ft(url)
    with pytest.raises(FTURLError, match="unknown parameter"):
        open_ft(url + "?speeed=2")
    with pytest.raises(FTURLError, match="no file"):
        open_ft("csv://")


HEADER = "t,Fx,Fy,Fz,Tx,Ty,Tz,sequence"


def test_a_non_utf8_byte_spoils_only_its_row(tmp_path: Path) -> None:
    path = tmp_path / "ft.csv"
    path.write_bytes(
        f"{HEADER}\n0,1,0,0,0,0,0,0\n0.1,\xff2,0,0,0,0,0,1\n0.2,3,0,0,0,0,0,2\n".encode("latin-1")
    )
    with open_ft(f"csv://{path}") as ft:
        rows = ft.read(5, timeout=1)
        assert rows["wrench"][:, 0].tolist() == [1.0, 3.0]
        assert ft.stats.bad_frames == 1


def test_a_header_only_file_is_refused_by_name(tmp_path: Path) -> None:
    url = write(tmp_path / "ft.csv", HEADER, [])
    with pytest.raises(FTConfigError, match="no sample rows"):
        open_ft(url)


def test_a_file_without_one_good_row_is_refused(tmp_path: Path) -> None:
    url = write(tmp_path / "ft.csv", HEADER, ["x,y", "0,nan,0,0,0,0,0,0"])
    with pytest.raises(FTConfigError, match="none of its 2 rows is a valid sample"):
        open_ft(url)


@pytest.mark.parametrize("sequence", ["nan", "inf", "-1", "1.5", "1e300"])
def test_a_sequence_that_is_not_a_count_makes_its_row_bad(tmp_path: Path, sequence: str) -> None:
    url = write(tmp_path / "ft.csv", HEADER, ["0,1,0,0,0,0,0,0", f"0.1,2,0,0,0,0,0,{sequence}",
                                              "0.2,3,0,0,0,0,0,1"])  # fmt: skip
    with open_ft(url) as ft:
        rows = ft.read(5, timeout=1)
        assert rows["sequence"].tolist() == [0, 1]
        assert (ft.stats.bad_frames, ft.stats.lost) == (1, 0)


@pytest.mark.parametrize("option", ["rate=nan", "rate=inf", "speed=nan", "speed=-inf"])
def test_non_finite_pacing_is_refused(tmp_path: Path, option: str) -> None:
    url = write(tmp_path / "ft.csv", HEADER, ["0,1,0,0,0,0,0,0"])
    with pytest.raises(FTURLError, match="must be a finite number"):
        open_ft(f"{url}?{option}")


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    body=st.binary(max_size=300),
    line=st.lists(st.sampled_from(["0", "1.5", "nan", "-1", "x", "", "1e400", "\xff"]), max_size=9),
)
def test_any_file_gives_samples_or_a_typed_error(
    tmp_path: Path, body: bytes, line: list[str]
) -> None:
    path = tmp_path / "fuzz.csv"
    path.write_bytes(f"{HEADER}\n".encode() + ",".join(line).encode("latin-1") + b"\n" + body)
    try:
        with open_ft(f"csv://{path}") as ft:
            rows = ft.read(10_000, timeout=1)
    except FTError:
        return
    assert np.all(np.isfinite(rows["wrench"])) and np.all(np.isfinite(rows["sensor_time"]))
    assert ft.stats.lost < 2**53 and len(rows) >= 1
