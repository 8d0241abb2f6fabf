"""Which physical effect the model lacks: each candidate effect's fit, its checks (significance,
consistency, plausibility, confounding), the ranking and verdict, and adding an effect as a new
model revision. Imports analysis and the layers below.
"""
