"""The library's decisions, one entry point per task kind (docs/architecture.md, "Entry points").

    from synth.solve import SynthesisOptions, DesignOptions, solve_bennett
    ps = synth.io.poses.load_poses("fixtures/bennett_quat.yaml")
    R = solve_bennett(ps, SynthesisOptions(physical=True))   # R.linkage, R.design, R.sentence()

`solve_bennett`, `solve_sixbar`, `solve_fourbar`, `solve_points`, `solve_curve` (`synth.solve.tasks`) are what
`mpsynth bennett|sixbar|curve` and `mpsynth batch` call: the same gates, ranking and choice of design
for a shell user and a notebook user. Layer: below `synth.io` (which writes a Result), above
`synth.design` and `synth.synthesis`.
"""
from synth import lazy_names

__all__ = ["DesignOptions", "SynthesisOptions", "Result", "Solution", "solve_bennett", "solve_sixbar", "solve_fourbar", "solve_points",
           "solve_curve", "design_solution"]

# loaded on first use (PEP 562), as `synth`'s names: `synth.solve.many` (the batch's chunk path) is imported
# without the design search and the writers that `synth.solve.tasks` brings
_LAZY = {name: "synth.solve.options" if name.endswith("Options") else "synth.solve.tasks" for name in __all__}
__getattr__, __dir__ = lazy_names(_LAZY, globals(), "synth.solve")
