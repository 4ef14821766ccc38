"""Experiments: run a decision task on a decision model under a privacy filter.

* :mod:`fairaudit.experiments.run`: one experiment end to end
  (``fairaudit experiment``), exact from a kernel or sampled through the
  filter, on a model source with run options (:mod:`fairaudit.experiments.options`); :mod:`fairaudit.experiments.harness`: the queries, their log and
  resumption; :mod:`fairaudit.experiments.analysis`: the fairness of the
  decision table and the ε per target; :mod:`fairaudit.experiments.report`:
  its JSON and Markdown; :mod:`fairaudit.experiments.local_model`: a small
  language model run offline, exactly from its log-probabilities.

* :mod:`fairaudit.experiments.navigation`: S3DIS-format scans to top-view,
  traversability and topological maps, A* candidate routes and route images
  (extra ``fairness-certify[navigation]``).
* :mod:`fairaudit.experiments.vlm`: the paper's prompts, the privacy filter on
  profile attributes, decision models (an OpenAI-compatible chat-completions
  client and simulated models) and reply parsing (extra ``fairness-certify[vlm]``).

* :mod:`fairaudit.experiments.cli`: the commands ``fairaudit experiment`` and
  ``fairaudit prepare-model``, entry points of the group ``fairaudit.commands``.

A plug-in on the public API: it imports only names of ``fairaudit.__all__``
(``tests/test_plugin_boundary.py``), and the core imports nothing of it. The
adapters only produce decision tables P(U | X̃, Ã) with counts; the core
certifies them (docs/design.md, "The plug-in interface").
"""
