//! # model-description — FMI 2.0 and 3.0 `modelDescription.xml` as typed Rust structs
//!
//! The subset of the FMI 2.0 schema a co-simulation slave with real-valued variables
//! needs, mirroring the schema's element and attribute names (optional attributes are
//! `Option`), written and read with quick-xml's serde support. [`fmi3`] holds the FMI 3.0
//! counterpart, derived from an FMI 2.0 description so both come from one variable table.
//!
//! ```
//! use model_description::*;
//! let md = ModelDescription::co_simulation("m", "{1234}", "mtwin_tcp")
//!     .with_real("Fx", "input", Some(0.0), Some("N"))
//!     .with_real("dx", "output", None, Some("m"));
//! let xml = md.to_xml().unwrap();
//! let back = ModelDescription::from_xml(&xml).unwrap();
//! assert_eq!(back, md);
//! assert_eq!(back.model_structure.outputs.unknowns[0].index, 2);
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

use serde::{Deserialize, Serialize};

pub mod fmi3;

/// Errors of (de)serialisation.
#[derive(Debug)]
pub struct Error(pub String);

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

/// `<fmiModelDescription>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "fmiModelDescription")]
pub struct ModelDescription {
    /// Always "2.0".
    #[serde(rename = "@fmiVersion")]
    pub fmi_version: String,
    /// Model name.
    #[serde(rename = "@modelName")]
    pub model_name: String,
    /// GUID, checked by the slave at instantiation.
    #[serde(rename = "@guid")]
    pub guid: String,
    /// Description.
    #[serde(
        rename = "@description",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub description: Option<String>,
    /// Generating tool.
    #[serde(
        rename = "@generationTool",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub generation_tool: Option<String>,
    /// When the FMU was generated (ISO 8601, UTC: `2026-11-25T18:53:41Z`).
    #[serde(
        rename = "@generationDateAndTime",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub generation_date_and_time: Option<String>,
    /// "flat" or "structured".
    #[serde(
        rename = "@variableNamingConvention",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub variable_naming_convention: Option<String>,
    /// Number of event indicators (0 for co-simulation).
    #[serde(
        rename = "@numberOfEventIndicators",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub number_of_event_indicators: Option<u32>,
    /// `<CoSimulation>`.
    #[serde(rename = "CoSimulation")]
    pub co_simulation: CoSimulation,
    /// `<UnitDefinitions>`.
    #[serde(
        rename = "UnitDefinitions",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub unit_definitions: Option<UnitDefinitions>,
    /// `<LogCategories>`.
    #[serde(
        rename = "LogCategories",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub log_categories: Option<LogCategories>,
    /// `<DefaultExperiment>`.
    #[serde(
        rename = "DefaultExperiment",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub default_experiment: Option<DefaultExperiment>,
    /// `<ModelVariables>`.
    #[serde(rename = "ModelVariables")]
    pub model_variables: ModelVariables,
    /// `<ModelStructure>`.
    #[serde(rename = "ModelStructure")]
    pub model_structure: ModelStructure,
}

/// `<CoSimulation>` capabilities.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoSimulation {
    /// Name of the shared library (without extension) and prefix-free function names.
    #[serde(rename = "@modelIdentifier")]
    pub model_identifier: String,
    /// Variable communication step sizes are handled.
    #[serde(
        rename = "@canHandleVariableCommunicationStepSize",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_handle_variable_communication_step_size: Option<bool>,
    /// `fmi2GetFMUstate`/`fmi2SetFMUstate` supported.
    #[serde(
        rename = "@canGetAndSetFMUstate",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_get_and_set_fmu_state: Option<bool>,
    /// FMU state serialisation supported.
    #[serde(
        rename = "@canSerializeFMUstate",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_serialize_fmu_state: Option<bool>,
    /// The slave does not use the importer's memory functions.
    #[serde(
        rename = "@canNotUseMemoryManagementFunctions",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_not_use_memory_management_functions: Option<bool>,
    /// Several instances per process are possible.
    #[serde(
        rename = "@canBeInstantiatedOnlyOncePerProcess",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_be_instantiated_only_once_per_process: Option<bool>,
}

/// `<UnitDefinitions>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnitDefinitions {
    /// The units.
    #[serde(rename = "Unit", default)]
    pub units: Vec<Unit>,
}

/// `<Unit name=..>` with its SI base unit exponents.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Unit {
    /// Unit name, e.g. "N".
    #[serde(rename = "@name")]
    pub name: String,
    /// `<BaseUnit>`.
    #[serde(rename = "BaseUnit", skip_serializing_if = "Option::is_none", default)]
    pub base_unit: Option<BaseUnit>,
}

/// `<BaseUnit kg= m= s=>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaseUnit {
    /// Exponent of kg.
    #[serde(rename = "@kg", skip_serializing_if = "Option::is_none", default)]
    pub kg: Option<i32>,
    /// Exponent of m.
    #[serde(rename = "@m", skip_serializing_if = "Option::is_none", default)]
    pub m: Option<i32>,
    /// Exponent of s.
    #[serde(rename = "@s", skip_serializing_if = "Option::is_none", default)]
    pub s: Option<i32>,
}

/// `<LogCategories>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct LogCategories {
    /// The categories.
    #[serde(rename = "Category", default)]
    pub categories: Vec<Category>,
}

/// `<Category name= description=>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Category {
    /// Category name, e.g. `logStatusWarning`.
    #[serde(rename = "@name")]
    pub name: String,
    /// What it logs.
    #[serde(
        rename = "@description",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub description: Option<String>,
}

/// `<DefaultExperiment>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DefaultExperiment {
    /// Start time in s.
    #[serde(
        rename = "@startTime",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub start_time: Option<f64>,
    /// Stop time in s.
    #[serde(rename = "@stopTime", skip_serializing_if = "Option::is_none", default)]
    pub stop_time: Option<f64>,
    /// Communication step in s.
    #[serde(rename = "@stepSize", skip_serializing_if = "Option::is_none", default)]
    pub step_size: Option<f64>,
}

/// `<ModelVariables>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelVariables {
    /// The scalar variables, in order (1-based indices refer to this list).
    #[serde(rename = "ScalarVariable", default)]
    pub variables: Vec<ScalarVariable>,
}

/// `<ScalarVariable>` (real-valued only).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScalarVariable {
    /// Unique name.
    #[serde(rename = "@name")]
    pub name: String,
    /// Value reference.
    #[serde(rename = "@valueReference")]
    pub value_reference: u32,
    /// Description.
    #[serde(
        rename = "@description",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub description: Option<String>,
    /// input, output, parameter, local, independent, ...
    #[serde(
        rename = "@causality",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub causality: Option<String>,
    /// continuous, discrete, fixed, tunable, constant.
    #[serde(
        rename = "@variability",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub variability: Option<String>,
    /// exact, approx, calculated (absent for inputs).
    #[serde(rename = "@initial", skip_serializing_if = "Option::is_none", default)]
    pub initial: Option<String>,
    /// `<Real>`.
    #[serde(rename = "Real")]
    pub real: Real,
}

/// `<Real>` type attributes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Real {
    /// Physical quantity, e.g. `Force`.
    #[serde(rename = "@quantity", skip_serializing_if = "Option::is_none", default)]
    pub quantity: Option<String>,
    /// Unit name.
    #[serde(rename = "@unit", skip_serializing_if = "Option::is_none", default)]
    pub unit: Option<String>,
    /// Smallest value.
    #[serde(rename = "@min", skip_serializing_if = "Option::is_none", default)]
    pub min: Option<f64>,
    /// Largest value.
    #[serde(rename = "@max", skip_serializing_if = "Option::is_none", default)]
    pub max: Option<f64>,
    /// Start value.
    #[serde(rename = "@start", skip_serializing_if = "Option::is_none", default)]
    pub start: Option<f64>,
}

/// `<ModelStructure>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModelStructure {
    /// `<Outputs>`.
    #[serde(rename = "Outputs", default)]
    pub outputs: Unknowns,
    /// `<InitialUnknowns>`.
    #[serde(rename = "InitialUnknowns", default)]
    pub initial_unknowns: Unknowns,
}

/// A list of `<Unknown>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Unknowns {
    /// The unknowns.
    #[serde(rename = "Unknown", default)]
    pub unknowns: Vec<Unknown>,
}

/// `<Unknown index= dependencies=>` (1-based index into ModelVariables).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Unknown {
    /// 1-based index of the variable.
    #[serde(rename = "@index")]
    pub index: u32,
    /// Space-separated 1-based indices of the variables it depends on.
    #[serde(
        rename = "@dependencies",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub dependencies: Option<String>,
}

impl ModelDescription {
    /// An empty co-simulation description.
    pub fn co_simulation(model_name: &str, guid: &str, model_identifier: &str) -> Self {
        ModelDescription {
            fmi_version: "2.0".into(),
            model_name: model_name.into(),
            guid: guid.into(),
            description: None,
            generation_tool: None,
            generation_date_and_time: None,
            variable_naming_convention: Some("flat".into()),
            number_of_event_indicators: Some(0),
            co_simulation: CoSimulation {
                model_identifier: model_identifier.into(),
                can_handle_variable_communication_step_size: Some(true),
                can_get_and_set_fmu_state: None,
                can_serialize_fmu_state: None,
                can_not_use_memory_management_functions: Some(true),
                can_be_instantiated_only_once_per_process: Some(false),
            },
            unit_definitions: None,
            log_categories: None,
            default_experiment: None,
            model_variables: ModelVariables { variables: vec![] },
            model_structure: ModelStructure::default(),
        }
    }

    /// Adds a continuous real input (with `start`) or output (listed in Outputs and
    /// InitialUnknowns, depending on every input declared before it). Value references
    /// are assigned in order from 0.
    pub fn with_real(
        mut self,
        name: &str,
        causality: &str,
        start: Option<f64>,
        unit: Option<&str>,
    ) -> Self {
        let vr = self.model_variables.variables.len() as u32;
        let is_output = causality == "output";
        self.model_variables.variables.push(ScalarVariable {
            name: name.into(),
            value_reference: vr,
            description: None,
            causality: Some(causality.into()),
            variability: Some("continuous".into()),
            initial: None,
            real: Real {
                unit: unit.map(Into::into),
                start: if is_output { None } else { start },
                ..Real::default()
            },
        });
        if is_output {
            let idx = self.model_variables.variables.len() as u32;
            let deps: Vec<String> = self
                .model_variables
                .variables
                .iter()
                .enumerate()
                .filter(|(_, v)| v.causality.as_deref() == Some("input"))
                .map(|(i, _)| (i + 1).to_string())
                .collect();
            let u = Unknown {
                index: idx,
                dependencies: Some(deps.join(" ")),
            };
            self.model_structure.outputs.unknowns.push(u.clone());
            self.model_structure.initial_unknowns.unknowns.push(u);
        }
        self
    }

    /// Adds a continuous real variable with a description and its `<Real>` attributes
    /// (for an output, `real.start` is dropped). An output is listed in Outputs and
    /// InitialUnknowns depending on every input declared before it, until
    /// [`ModelDescription::set_dependencies`] says otherwise.
    pub fn with_described_real(
        self,
        name: &str,
        causality: &str,
        description: &str,
        real: Real,
    ) -> Self {
        let mut md = self.with_real(name, causality, real.start, real.unit.as_deref());
        if let Some(v) = md.model_variables.variables.last_mut() {
            v.description = Some(description.into());
            let start = v.real.start;
            v.real = Real { start, ..real };
        }
        md
    }

    /// Sets the variables output `output` depends on (by name) in Outputs and
    /// InitialUnknowns; an empty list writes `dependencies=""` (depends on no input).
    /// Returns false when a name is unknown or `output` is not an output.
    pub fn set_dependencies(&mut self, output: &str, on: &[&str]) -> bool {
        let index_of = |n: &str| {
            self.model_variables
                .variables
                .iter()
                .position(|v| v.name == n)
                .map(|i| i as u32 + 1)
        };
        let Some(idx) = index_of(output) else {
            return false;
        };
        let Some(mut deps) = on.iter().map(|n| index_of(n)).collect::<Option<Vec<u32>>>() else {
            return false;
        };
        deps.sort_unstable();
        deps.dedup();
        let text = deps
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(" ");
        let mut found = false;
        for list in [
            &mut self.model_structure.outputs.unknowns,
            &mut self.model_structure.initial_unknowns.unknowns,
        ] {
            for u in list.iter_mut().filter(|u| u.index == idx) {
                u.dependencies = Some(text.clone());
                found = true;
            }
        }
        found
    }

    /// The XML text (with declaration).
    pub fn to_xml(&self) -> Result<String, Error> {
        xml_text(self)
    }

    /// Parses XML text.
    pub fn from_xml(xml: &str) -> Result<Self, Error> {
        quick_xml::de::from_str(xml).map_err(|e| Error(e.to_string()))
    }
}

/// `value` as XML text with declaration, indented by two spaces.
fn xml_text<T: Serialize>(value: &T) -> Result<String, Error> {
    let mut body = String::new();
    let mut ser = quick_xml::se::Serializer::new(&mut body);
    ser.indent(' ', 2);
    value.serialize(ser).map_err(|e| Error(e.to_string()))?;
    Ok(format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{body}\n"
    ))
}
