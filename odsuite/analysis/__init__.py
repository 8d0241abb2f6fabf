"""What the measurements and the model say: the model's prediction through the same chain, the
calibrated noise floor, the comparison and its history, FRFs, modal identification (input-output
and output-only), operating shapes, the model-corrected measurement. Imports processing and the
layers below.
"""
