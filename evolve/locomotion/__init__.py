"""Seed 000's locomotion task: a symmetric NEAT controller walking a biped in MuJoCo."""
