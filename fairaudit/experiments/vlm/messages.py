"""The chat messages of the OpenAI chat-completions format: a user message with images, a system message.

:meth:`fairaudit.experiments.vlm.tasks.DeliveryTask.messages` builds a query's messages from these two, and
:class:`fairaudit.experiments.vlm.client.ChatClient` sends them (which re-exports both). The module needs nothing
beyond the standard library. :func:`chatml` renders text messages as one prompt for a server's text completions.
"""

from __future__ import annotations

import base64
import re
from collections.abc import Sequence

from fairaudit import InputError

__all__ = ["CHATML", "chatml", "system_message", "user_message"]


def user_message(text: str, images: Sequence[bytes] = (), *, mime: str = "image/png") -> dict:
    """An OpenAI chat message from the user: text, then images as base64 data URLs.

    Parameters
    ----------
    text : str
        The prompt.
    images : sequence of bytes
        Encoded images (PNG, JPEG, ...), in order; each non-empty. Not a
        single ``bytes`` object: wrap one image in a list.
    mime : str
        The images' media type, ``image/...`` (``image/png``, ``image/jpeg``).

    Returns
    -------
    dict
        ``{"role": "user", "content": text}`` without images, else
        ``{"role": "user", "content": [{"type": "text", "text": text},
        {"type": "image_url", "image_url": {"url": "data:<mime>;base64,..."}}, ...]}``.

    Raises
    ------
    InputError
        When ``text`` is not a string, an image is not non-empty bytes, or
        ``mime`` is not an image media type.

    Examples
    --------
    >>> user_message("Which office?")
    {'role': 'user', 'content': 'Which office?'}
    >>> m = user_message("Which office?", [b"\\x89PNG"])
    >>> m["content"][0]
    {'type': 'text', 'text': 'Which office?'}
    >>> m["content"][1]
    {'type': 'image_url', 'image_url': {'url': 'data:image/png;base64,iVBORw=='}}
    """
    if not isinstance(text, str):
        raise InputError("text", "must be a string", text)
    if isinstance(images, (bytes, bytearray, memoryview, str)):
        raise InputError("images", "must be a sequence of images (wrap a single image in a list)")
    if not isinstance(mime, str) or not re.fullmatch(r"image/[A-Za-z0-9.+-]+", mime):
        raise InputError("mime", "must be an image media type such as 'image/png' or 'image/jpeg'", mime)
    try:
        images = list(images)
    except TypeError:
        raise InputError("images", "must be a sequence of bytes", type(images).__name__) from None
    if not images:
        return {"role": "user", "content": text}
    content: list[dict] = [{"type": "text", "text": text}]
    for i, image in enumerate(images):
        if not isinstance(image, (bytes, bytearray, memoryview)) or len(image) == 0:
            raise InputError(f"images[{i}]", "must be non-empty bytes (an encoded image)", type(image).__name__)
        encoded = base64.b64encode(bytes(image)).decode("ascii")
        content.append({"type": "image_url", "image_url": {"url": f"data:{mime};base64,{encoded}"}})
    return {"role": "user", "content": content}


def system_message(text: str) -> dict:
    """An OpenAI system message ``{"role": "system", "content": text}``.

    Raises
    ------
    InputError
        When ``text`` is not a string.

    Examples
    --------
    >>> system_message("You are a delivery robot.")
    {'role': 'system', 'content': 'You are a delivery robot.'}
    """
    if not isinstance(text, str):
        raise InputError("text", "must be a string", text)
    return {"role": "system", "content": text}


CHATML = (
    "ChatML: each message as <|im_start|>{role}\\n{content}<|im_end|>\\n, then <|im_start|>assistant\\n and the "
    "reply's text"
)
"""The rendering :func:`chatml` applies, in words (``run.scoring.rendering`` of a text-completions route)."""


def chatml(messages: Sequence[dict]) -> str:
    """Text chat messages as one prompt in ChatML, open for the assistant's reply.

    A server's text completions (``/v1/completions``) take a prompt, not messages, and do not say which chat
    template their model was trained with; this is the stated rendering under which such a route scores a reply
    (:data:`CHATML`; the template of the Qwen and SmolLM2 families, among others, without their default system
    message).

    Parameters
    ----------
    messages : sequence of dict
        Chat messages, each ``{"role": str, "content": str}`` (text only).

    Returns
    -------
    str
        ``<|im_start|>{role}\\n{content}<|im_end|>\\n`` per message, then ``<|im_start|>assistant\\n``.

    Raises
    ------
    InputError
        ``messages[i]`` when a message has no string role or its content is not text (images).

    Examples
    --------
    >>> chatml([system_message("Answer yes or no."), user_message("Approve?")])
    '<|im_start|>system\\nAnswer yes or no.<|im_end|>\\n<|im_start|>user\\nApprove?<|im_end|>\\n<|im_start|>assistant\\n'
    """
    parts = []
    for i, message in enumerate(messages):
        role, content = message.get("role"), message.get("content")
        if not isinstance(role, str) or not isinstance(content, str):
            raise InputError(f"messages[{i}]", "must have a string role and text content to be rendered as ChatML")
        parts.append(f"<|im_start|>{role}\n{content}<|im_end|>\n")
    return "".join(parts) + "<|im_start|>assistant\n"
