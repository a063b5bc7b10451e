"""Malformed and hostile vendor URDFs and xacro macros through ``export --urdf-like``
(tests/fuzz_urdf_like.py): refused in one line with nothing written, or written whole; and a vendor
file whose tool0 is off the flange refused (it was written, exit 0, with its FK that far off)."""

from __future__ import annotations

import pytest
from fuzz_urdf import cli, one_error_line
from fuzz_urdf_like import DATA, fuzz

FAST = 60
SLOW = 1000


def test_vendor_file_mutants_keep_the_contract(tmp_path):
    problems = fuzz(FAST, 0, tmp_path)
    assert not problems, "\n".join(problems[:5])


@pytest.mark.slow
def test_many_vendor_file_mutants_keep_the_contract(tmp_path):
    problems = fuzz(SLOW, 1, tmp_path)
    assert not problems, "\n".join(problems[:5])


@pytest.mark.parametrize("old, new", [
    (b'xyz="0.158 0 0"', b'xyz="1.158 0 0"'),  # the flange 1 m out: tool0 0.95 m off, exit 0
    (b'<origin rpy="0 1.5707963267948966 0" xyz="0 0 0"/>',
     b'<origin rpy="0 1.5707963267948966 0" xyz="0 0 0.3"/>'),
])
def test_a_vendor_tool0_off_the_flange_is_refused(tmp_path, old, new):
    text = (DATA / "kr16_2.urdf").read_bytes()
    assert old in text
    (tmp_path / "v.urdf").write_bytes(text.replace(old, new, 1))
    out = tmp_path / "o.urdf"
    code, err = cli(["export", "kuka_kr16_2", "--urdf-like", str(tmp_path / "v.urdf"), "-o", str(out)])
    assert one_error_line(code, err) and "from the model's flange" in err and not out.exists()


@pytest.mark.parametrize("old, new", [(b'<link name="link_2"', b'<link name="link_1"'),
                                      (b'<joint name="joint_a2"', b'<joint name="joint_a1"')])
def test_a_vendor_file_with_a_name_given_twice_is_refused(tmp_path, old, new):
    """Two links named link_1 (a file ROS refuses) were written, exit 0."""
    (tmp_path / "v.urdf").write_bytes((DATA / "kr16_2.urdf").read_bytes().replace(old, new, 1))
    out = tmp_path / "o.urdf"
    code, err = cli(["export", "kuka_kr16_2", "--urdf-like", str(tmp_path / "v.urdf"), "-o", str(out)])
    assert one_error_line(code, err) and "given 2 times" in err and not out.exists(), err
