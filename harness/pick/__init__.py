"""The Pick skill: semantics policy, command targets, candidate walk, command list, executor and
verdict terms."""
