"""Opens rift's .usda files with Pixar's usd-core, runs every registered UsdValidation validator,
and checks what rift promises to author. Prints one line per file; exits non-zero on any problem.

    python3 tests/support/usd_validate.py FILE.usda [...]
"""
import sys

from pxr import Usd, UsdGeom, UsdValidation, Sdf


def check(path):
    problems = []
    layer = Sdf.Layer.FindOrOpen(path)
    if layer is None:
        return [f"cannot open as a USD layer"]
    stage = Usd.Stage.Open(layer)
    registry = UsdValidation.ValidationRegistry()
    validators = registry.GetOrLoadAllValidators()
    context = UsdValidation.ValidationContext(validators)
    for error in context.Validate(stage):
        if error.GetType() in (UsdValidation.ValidationErrorType.Error,
                               UsdValidation.ValidationErrorType.Warn):
            problems.append(f"validator: {error.GetErrorAsString()}")

    if stage.GetTimeCodesPerSecond() <= 0 or stage.GetFramesPerSecond() != stage.GetTimeCodesPerSecond():
        problems.append("timeCodesPerSecond / framesPerSecond missing or inconsistent")
    if UsdGeom.GetStageUpAxis(stage) != UsdGeom.Tokens.y:
        problems.append("upAxis is not Y")
    if UsdGeom.GetStageMetersPerUnit(stage) != 1.0:
        problems.append("metersPerUnit is not 1")
    if not stage.GetDefaultPrim():
        problems.append("no defaultPrim")

    frame = stage.GetStartTimeCode()
    curves = [UsdGeom.BasisCurves(p) for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]
    if not curves:
        problems.append("no BasisCurves prim")
    for c in curves:
        name = c.GetPath()
        counts = c.GetCurveVertexCountsAttr().Get(frame)
        points = c.GetPointsAttr().Get(frame)
        n = sum(counts)
        if c.GetWrapAttr().Get() != UsdGeom.Tokens.periodic:
            problems.append(f"{name}: curves are not periodic (closed)")
        if points is None or len(points) != n:
            problems.append(f"{name}: points missing at time {frame} or not matching curveVertexCounts")
            continue
        arrays = {
            "widths": c.GetWidthsAttr().Get(frame),
            "velocities": c.GetVelocitiesAttr().Get(frame),
            "accelerations": c.GetAccelerationsAttr().Get(frame),
            "primvars:displayColor": c.GetDisplayColorAttr().Get(frame),
            "primvars:intensity": UsdGeom.PrimvarsAPI(c).GetPrimvar("intensity").Get(frame),
        }
        for key, values in arrays.items():
            if values is None or len(values) != n:
                problems.append(f"{name}: {key} missing or of the wrong length")
        for key in ("widths", "primvars:displayColor", "primvars:intensity"):
            pv = UsdGeom.PrimvarsAPI(c).GetPrimvar(key.split(":")[-1]) if key.startswith("primvars:") else None
            interp = pv.GetInterpolation() if pv else c.GetWidthsInterpolation()
            if interp != UsdGeom.Tokens.vertex:
                problems.append(f"{name}: {key} interpolation is {interp}, expected vertex")
        extent = c.GetExtentAttr().Get(frame)
        computed = UsdGeom.Boundable.ComputeExtentFromPlugins(c, frame)
        if extent is None or computed is None:
            problems.append(f"{name}: no extent")
        else:
            for a, b in zip(list(extent[0]) + list(extent[1]), list(computed[0]) + list(computed[1])):
                if abs(a - b) > 1e-4 * (1 + abs(b)):
                    problems.append(f"{name}: authored extent {extent} differs from computed {computed}")
                    break
    return problems


def main(paths):
    if not paths:
        print("usage: usd_validate.py FILE.usda [...]", file=sys.stderr)
        return 2
    failed = 0
    for path in paths:
        problems = check(path)
        status = "ok" if not problems else "FAILED"
        print(f"{path}: {status}")
        for p in problems:
            print(f"  {p}")
        failed += bool(problems)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
