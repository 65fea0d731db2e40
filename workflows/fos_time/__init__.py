"""The factor of safety against time of a study with ``[transient]`` (``workflows.transient``): a case
per time (``study_type``), ``fos_time.nc`` (``results``) and ``fos_time.png`` (``figures``)."""
