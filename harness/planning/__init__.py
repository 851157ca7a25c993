"""Planning a pick: IK (``ik``), the planning world (``world``), collision checks
(``collision``), path search (``paths``), plans and verdicts (``plans``), the pick planner
(``planner``) and time parameterisation (``timing``)."""
