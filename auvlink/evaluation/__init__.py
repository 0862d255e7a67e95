"""Evaluation that runs whole missions or passes: the application layer's measuring tools (tests,
benchmarks, ``auvlink eval``). Nothing is imported here; import the module you use:

- :mod:`auvlink.evaluation.simeval`: recon against the simulator's ground truth (rendered surveys,
  cluster errors, point-to-mesh accuracy, dead-reckoning drift on a simulated log).
- :mod:`auvlink.evaluation.recon_eval`: clouds recon reconstructs from simulated passes over single
  objects, and the classifier scored on them (``auvlink eval --recon``, ``auvlink train --recon-eval``).
- :mod:`auvlink.evaluation.noncausal_reference`: the non-causal batch reference of the pipeline on a mission log.
"""
