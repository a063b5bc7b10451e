"""What the three run-time correction writers share (robocal.programs.runtime.RuntimeWriter): a
file already holding the routine, or naming one of its functions, is refused with the name found,
before anything is added; a file without either gets the routine."""

from __future__ import annotations

import pytest

import robocal as rc
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.programs.dialects.krl.runtime import BEGIN as KRL_BEGIN
from robocal.programs.dialects.krl.runtime import KRLRuntime
from robocal.programs.dialects.rapid.runtime import BEGIN as RAPID_BEGIN
from robocal.programs.dialects.rapid.runtime import RapidRuntime
from robocal.programs.dialects.urscript.runtime import BEGIN as UR_BEGIN
from robocal.programs.dialects.urscript.runtime import URScriptRuntime
from robocal.programs.runtime import calibrated_chain

NOMINAL = rc.Robot.from_catalog("abb_irb2600")
CHAIN = calibrated_chain(perturbed(NOMINAL, 3), NOMINAL)
# (writer, a plain file of its language, a name of its routine written as a program might, its marker)
CASES = [(RapidRuntime, "MODULE M\n  PROC m()\n  ENDPROC\nENDMODULE\n", "rc_fk", RAPID_BEGIN),
         (KRLRuntime, "DEF m()\nEND\n", "rc_const", KRL_BEGIN),
         (URScriptRuntime, "def m():\n  sleep(1)\nend\n", "RC_FK", UR_BEGIN)]


@pytest.mark.parametrize(("writer", "text", "name", "begin"), CASES)
def test_a_file_naming_the_routine_or_holding_it_is_refused(writer, text, name, begin):
    at, routine = writer().routine(text, CHAIN, [], "robocal test")
    assert begin in routine and 0 <= at <= len(text)
    named = text.replace("m()", f"m()\n  {name} = 1", 1)
    with pytest.raises(DataError, match=f"already names {name}"):
        writer().routine(named, CHAIN, [], "robocal test")
    with pytest.raises(DataError, match="already holds robocal's run-time correction"):
        writer().routine(text[:at] + routine + text[at:], CHAIN, [], "robocal test")
