"""JUnit XML helpers shared by the gate and diff reports."""
from __future__ import annotations


def xml_text(text: str) -> str:
    """Text XML 1.0 can carry: control characters and lone surrogates (undecodable file names) replaced."""
    return "".join(c if (c in "\t\n\r" or " " <= c <= "\ud7ff" or "\ue000" <= c <= "\ufffd") else "\ufffd"
                   for c in str(text))
