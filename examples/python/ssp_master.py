"""A co-simulation master that knows only FMI 2.0 and SSP 1.0: it reads
`SystemStructure.ssd` from an `.ssp` package, instantiates every component FMU with
fmpy's FMU2Slave, applies the parameter bindings (start values) in initialization mode,
and steps the system with a fixed communication step. At each communication point the
connections are propagated in the order the SSD lists them (output read after the
inputs it depends on were set: Gauss-Seidel), then every component steps.
Nothing here knows what the components are."""
import pathlib
import zipfile
import xml.etree.ElementTree as ET

from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave

NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
}


class System:
    def __init__(self, ssp, workdir, overrides=None):
        """`overrides`: {(component, parameter): value} applied after the SSD's bindings."""
        workdir = pathlib.Path(workdir)
        with zipfile.ZipFile(ssp) as z:
            z.extractall(workdir)
        root = ET.parse(workdir / "SystemStructure.ssd").getroot()
        system = root.find("ssd:System", NS)
        self.components = {}
        self.refs = {}
        for comp in system.find("ssd:Elements", NS).findall("ssd:Component", NS):
            name = comp.get("name")
            fmu = workdir / comp.get("source")
            unzip = workdir / f"_{name}"
            with zipfile.ZipFile(fmu) as z:
                z.extractall(unzip)
            md = read_model_description(str(fmu))
            s = FMU2Slave(guid=md.guid, unzipDirectory=str(unzip),
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
            self.components[name] = s
            self.refs[name] = {v.name: v.valueReference for v in md.modelVariables}
            self.bindings = getattr(self, "bindings", {})
            for p in comp.findall(".//ssv:Parameter", NS):
                self.bindings[(name, p.get("name"))] = float(p.find("ssv:Real", NS).get("value"))
        self.bindings.update(overrides or {})
        self.connections = [
            (c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
            for c in system.find("ssd:Connections", NS).findall("ssd:Connection", NS)
        ]

    def initialize(self, t0=0.0):
        for name, s in self.components.items():
            s.instantiate()
            s.setupExperiment(startTime=t0)
            s.enterInitializationMode()
            for (c, p), v in self.bindings.items():
                if c == name:
                    s.setReal([self.refs[c][p]], [v])
            s.exitInitializationMode()

    def propagate(self):
        for se, sc, ee, ec in self.connections:
            v = self.components[se].getReal([self.refs[se][sc]])[0]
            self.components[ee].setReal([self.refs[ee][ec]], [v])

    def get(self, comp, names):
        return self.components[comp].getReal([self.refs[comp][n] for n in names])

    def step(self, t, h):
        for s in self.components.values():
            s.doStep(t, h)

    def close(self):
        for s in self.components.values():
            s.terminate()
            s.freeInstance()


def bindings(ssp):
    """{(component, parameter): value} of the SSD's parameter bindings."""
    with zipfile.ZipFile(ssp) as z:
        root = ET.fromstring(z.read("SystemStructure.ssd"))
    out = {}
    for comp in root.iter(f"{{{NS['ssd']}}}Component"):
        for p in comp.iter(f"{{{NS['ssv']}}}Parameter"):
            out[(comp.get("name"), p.get("name"))] = float(p.find("ssv:Real", NS).get("value"))
    return out


def run(ssp, workdir, h, n, record, overrides=None):
    """Runs n steps of size h; returns the values of `record` = (component, [names])
    at every communication point (after the connections were propagated)."""
    sysm = System(ssp, workdir, overrides)
    sysm.initialize()
    comp, names = record
    out = []
    for i in range(n):
        sysm.propagate()
        out.append(sysm.get(comp, names))
        sysm.step(i * h, h)
    sysm.close()
    return out
