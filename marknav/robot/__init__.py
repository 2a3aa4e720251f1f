"""Drivers: the Create Open Interface protocol, serial transport and the safety state machine."""
