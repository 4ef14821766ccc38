"""VLM querying plug-in: prompts, privacy filter, decision models and reply parsing (extra ``fairness-certify[vlm]``)."""
