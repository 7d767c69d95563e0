"""Distillation of the model-based controller into a neural policy and its preservative fine-tuning."""
