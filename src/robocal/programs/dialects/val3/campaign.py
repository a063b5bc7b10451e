"""Staubli VAL3 campaign applications (:mod:`robocal.campaign.programs`): an application folder NAME/
with ``NAME.pjx``, ``start.pgx`` (per pose ``movej(jPose[k], flange, mCampaign)``, ``waitEndMove()``,
``delay(settle)``, ``call procedure(k)``), ``stop.pgx``, the procedure's ``.pgx`` (a ``num``
parameter; its body only writes a message) and ``NAME.dtx`` declaring ``jPose`` (jointRx, deg) and
``mCampaign`` (mdesc, ``vel`` = the speed percentage, blend off). XML as the Staubli editor writes it
(UTF-8, CRLF)."""

from __future__ import annotations

from robocal.core.errors import DataError
from robocal.core.escape import cdata_text
from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    DEGREE_DECIMALS,
    checked_joints,
    comment_lines,
    fixed_point,
    identifier,
)

VAL3_NAME_MAX = 15                 # VAL3 application and program names (CS8 limit)


def val3_application(joints_deg, name: str = "robocalCampaign", *,
                     speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
                     procedure: str = DEFAULT_PROCEDURE, comment: str = "") -> dict[str, str]:
    """Staubli VAL3 application visiting ``joints_deg (N, 6)`` in order: file name -> text (see the
    module docstring)."""
    q = checked_joints(joints_deg, speed_percent, settle_s, "VAL3")
    name = identifier(name, "the VAL3 application name (the folder name)", VAL3_NAME_MAX)
    procedure = identifier(procedure, "the procedure (program) name", VAL3_NAME_MAX)
    if procedure in ("start", "stop"):
        raise DataError(f"the procedure cannot be named {procedure}: start and stop are the application's")
    head = '<?xml version="1.0" encoding="utf-8"?>'
    ns = 'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns="http://www.staubli.com/robotics/VAL3'
    # the comment is in the code's CDATA: a "]]>" in it (a model's name) would end the section
    code = ["begin", *(f"  // {cdata_text(line)}" for line in comment_lines(comment, len(q)))]
    for k in range(len(q)):
        code += [f"  movej(jPose[{k}], flange, mCampaign)", "  waitEndMove()",
                 f"  delay({fixed_point(settle_s, 3)})", f"  call {procedure}({k + 1})"]
    code.append("end")

    def pgx(prog: str, body: list[str], params: tuple[str, ...] = ()) -> str:
        return "\n".join([head, f'<Programs {ns}/Program/2">', f'  <Program name="{prog}" access="public">',
                          *params, "    <Code><![CDATA[" + "\n".join(body), "]]></Code>", "  </Program>",
                          "</Programs>", ""])

    data = '    <Data name="{}" access="public" xsi:type="array" type="{}" size="{}">'
    dtx = [head, f'<Database {ns}/Data/2">', "  <Datas>", data.format("jPose", "jointRx", len(q))]
    for k, row in enumerate(q):
        joints = " ".join(f'j{i + 1}="{fixed_point(v, DEGREE_DECIMALS)}"' for i, v in enumerate(row))
        dtx.append(f'      <Value key="{k}" {joints} />')
    dtx += ["    </Data>", data.format("mCampaign", "mdesc", 1),
            f'      <Value key="0" vel="{fixed_point(speed_percent, 3)}" blend="off" />', "    </Data>",
            "  </Datas>", "</Database>", ""]
    pjx = [head, '<Project xmlns="http://www.staubli.com/robotics/VAL3/Project/3">',
           '  <Parameters version="s7.11" stackSize="5000" millimeterUnit="true" />', "  <Programs>",
           *(f'    <Program file="{f}.pgx" />' for f in ("start", "stop", procedure)), "  </Programs>",
           "  <Database>", f'    <Data file="{name}.dtx" />', "  </Database>", "  <Libraries />",
           "</Project>", ""]
    param = ('    <Parameters xmlns="http://www.staubli.com/robotics/VAL3/Param/1">',
             '      <Parameter name="x_nPose" type="num" xsi:type="element" />', "    </Parameters>")
    measure = ["begin", "  // trigger the tracker measurement here",
               '  putln("robocal: measure pose " + toString("", x_nPose))', "end"]
    files = {f"{name}.pjx": "\n".join(pjx), "start.pgx": pgx("start", code),
             "stop.pgx": pgx("stop", ["begin", "  resetMotion()", "end"]),
             f"{procedure}.pgx": pgx(procedure, measure, param), f"{name}.dtx": "\n".join(dtx)}
    return {k: v.replace("\n", "\r\n") for k, v in files.items()}
