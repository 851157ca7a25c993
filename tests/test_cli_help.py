"""Every argument of every ``harness`` command says what it is for in ``--help``."""

from __future__ import annotations

import argparse

from harness.cli import build_parser


def _arguments_without_help(parser: argparse.ArgumentParser, path: str) -> list[str]:
    missing: list[str] = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                missing += _arguments_without_help(sub, f"{path} {name}")
        elif not isinstance(action, argparse._HelpAction) and not action.help:
            missing.append(f"{path} {'/'.join(action.option_strings) or action.dest}")
    return missing


def test_every_argument_has_help() -> None:
    assert _arguments_without_help(build_parser(), "harness") == []


def test_the_checker_sees_an_argument_without_help() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--bare")
    assert _arguments_without_help(parser, "x") == ["x --bare"]
