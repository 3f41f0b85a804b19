"""Prints what the C drivers need to know about an FMU, one item per line:
GUID, the Real input value references (comma-separated), the Real output value references.
usage: fmu_info.py FMU_OR_EXTRACTED_DIR"""
import sys

from fmpy import read_model_description

md = read_model_description(sys.argv[1])
real = [v for v in md.modelVariables if v.type == "Real"]
print(md.guid)
print(",".join(str(v.valueReference) for v in real if v.causality == "input"))
print(",".join(str(v.valueReference) for v in real if v.causality == "output"))
