"""The study file: one TOML file that describes a simulation, checked before anything runs.

- :mod:`workflows.fields`: how a field is declared, checked and documented;
- :mod:`workflows.study.tables`: the whole :class:`Study` and its checks across tables; the study's
  own tables by subject (``geometry``, ``supports``, ``solver``, ``records``, ``sweep``), the kinds'
  from their rooms (``workflows.materials``, ``workflows.stages``, ``workflows.loads``, and each
  room's ``table``: ``workflows.water.table``, ``workflows.seepage.table``, ...);
- :mod:`workflows.study.reading`: TOML text to a checked :class:`Study` (:func:`load_study`);
- :mod:`workflows.study.reference`: the JSON schema and the study-file reference page, both
  generated from the declarations.
"""

from workflows.fields import StudyError
from workflows.study.reading import load_study, parse_study
from workflows.study.records import Metrics
from workflows.study.tables import Study

__all__ = ["Metrics", "Study", "StudyError", "load_study", "parse_study"]
