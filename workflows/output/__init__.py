"""Result files: what they hold (declared once in :mod:`workflows.output.variables`), how a
stage's file is made (:mod:`~workflows.output.stage_file`) and written atomically
(:mod:`~workflows.output.writing`), collapse metrics (:mod:`~workflows.output.metrics`), ParaView
files (:mod:`~workflows.output.paraview`) and the generated reference page
(:mod:`~workflows.output.reference`)."""
