"""Test support: domain allocation and subprocess management."""
