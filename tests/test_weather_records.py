"""EPW records must follow each other by exactly one step: a duplicated, missing or out-of-order record
is an error naming its line (issue 10: such files were accepted), while a typical-year file that stitches
months of different years still reads."""

import pytest

from widesky.irradiance.weather import WeatherFileError, read_epw
from widesky.commands.sun import SAMPLE_WEATHER

HEADER = 8  # header lines of the sample file; record k is on line HEADER + 1 + k


@pytest.fixture
def lines():
    return SAMPLE_WEATHER.read_text().splitlines(keepends=True)


def write(tmp_path, lines):
    p = tmp_path / "w.epw"
    p.write_text("".join(lines))
    return p


def test_sample_reads(lines, tmp_path):
    w = read_epw(write(tmp_path, lines))
    assert len(w.data) == len(lines) - HEADER and w.data.index.is_monotonic_increasing


def test_duplicated_record_names_its_line(lines, tmp_path):
    dup = lines[: HEADER + 10] + [lines[HEADER + 9]] + lines[HEADER + 10:]
    with pytest.raises(WeatherFileError, match="duplicates the timestamp") as e:
        read_epw(write(tmp_path, dup))
    assert f":{HEADER + 11}:" in str(e.value) and f"line {HEADER + 10}" in str(e.value)


def test_missing_record_names_its_line(lines, tmp_path):
    gap = lines[: HEADER + 20] + lines[HEADER + 23:]  # three hours dropped
    with pytest.raises(WeatherFileError, match="3 record.s. of the 0 days 01:00:00 step missing") as e:
        read_epw(write(tmp_path, gap))
    assert f":{HEADER + 21}:" in str(e.value)


def test_out_of_order_record_names_its_line(lines, tmp_path):
    swapped = list(lines)
    swapped[HEADER + 5], swapped[HEADER + 6] = swapped[HEADER + 6], swapped[HEADER + 5]
    with pytest.raises(WeatherFileError, match="out of time order") as e:
        read_epw(write(tmp_path, swapped))
    assert f":{HEADER + 6}:" in str(e.value) and f"line {HEADER + 7}" in str(e.value)


def test_typical_year_months_from_different_years_read(lines, tmp_path):
    """A TMY file takes each month from another year: the year field may change where the calendar goes on."""
    stitched = list(lines)
    # from 6/20 on, the records claim another year: the calendar continues, so the file is accepted
    for i in range(HEADER, len(stitched)):
        f = stitched[i].split(",")
        if int(f[2]) >= 20:
            f[0] = "2009"
            stitched[i] = ",".join(f)
    w = read_epw(write(tmp_path, stitched))
    assert len(w.data) == len(lines) - HEADER
    # but a year change with a jump in the calendar is still a gap
    jump = stitched[: HEADER + 30] + stitched[HEADER + 31:]
    with pytest.raises(WeatherFileError, match="missing"):
        read_epw(write(tmp_path, jump))
