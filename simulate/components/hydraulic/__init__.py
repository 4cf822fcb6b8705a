"""Hydraulic components: penstock models, reservoir, headrace tunnel and surge tank."""
