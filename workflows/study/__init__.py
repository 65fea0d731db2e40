"""The study file: one TOML file that describes a simulation, checked before anything runs.

- :mod:`workflows.fields`: how a field is declared, checked and documented;
- :mod:`workflows.study.tables`: the tables of a study file and the whole :class:`Study` (the
  tables of materials, stages, loads and water come from their rooms: ``workflows.materials``,
  ``workflows.stages``, ``workflows.loads``, ``workflows.water.table``);
- :mod:`workflows.study.reading`: TOML text to a checked :class:`Study` (:func:`load_study`);
- :mod:`workflows.study.reference`: the JSON schema and the study-file reference page, both
  generated from the declarations.
"""

from workflows.fields import StudyError
from workflows.study.reading import load_study, parse_study
from workflows.study.tables import Metrics, Study

__all__ = ["Metrics", "Study", "StudyError", "load_study", "parse_study"]
