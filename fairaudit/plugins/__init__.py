"""Thin experiment plug-ins that run a decision model under a privacy filter.

* :mod:`fairaudit.plugins.navigation`: S3DIS-format scans to top-view,
  traversability and topological maps, A* candidate routes and route images
  (extra ``fairaudit[navigation]``).
* :mod:`fairaudit.plugins.vlm`: the paper's prompts, the privacy filter on
  profile attributes, decision models (an OpenAI-compatible chat-completions
  client and simulated models) and reply parsing (extra ``fairaudit[vlm]``).

They only produce decision tables P(U | X̃, Ã) with counts; the core
certifies them. Nothing here is imported by ``import fairaudit``.
"""
