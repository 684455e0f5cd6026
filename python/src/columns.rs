//! Columns to Python: a dict of numpy arrays and lists, made a pandas `DataFrame` when pandas is
//! installed (a dependency of the package; the dict is returned without it).

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Named columns of one table, all of one length.
#[derive(Default)]
pub(crate) struct Columns {
    names: Vec<&'static str>,
    values: Vec<Column>,
}

enum Column {
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    Text(Vec<String>),
}

impl Columns {
    pub fn f64(&mut self, name: &'static str, v: Vec<f64>) {
        self.names.push(name);
        self.values.push(Column::F64(v));
    }
    pub fn i64(&mut self, name: &'static str, v: Vec<i64>) {
        self.names.push(name);
        self.values.push(Column::I64(v));
    }
    pub fn bool(&mut self, name: &'static str, v: Vec<bool>) {
        self.names.push(name);
        self.values.push(Column::Bool(v));
    }
    pub fn text(&mut self, name: &'static str, v: Vec<String>) {
        self.names.push(name);
        self.values.push(Column::Text(v));
    }

    /// A `DataFrame` of the columns in order (the dict when pandas is missing).
    pub fn into_frame(self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let d = PyDict::new(py);
        for (name, column) in self.names.into_iter().zip(self.values) {
            match column {
                Column::F64(v) => d.set_item(name, PyArray1::from_vec(py, v))?,
                Column::I64(v) => d.set_item(name, PyArray1::from_vec(py, v))?,
                Column::Bool(v) => d.set_item(name, PyArray1::from_vec(py, v))?,
                Column::Text(v) => d.set_item(name, v)?,
            }
        }
        match py.import("pandas") {
            Ok(pandas) => Ok(pandas.getattr("DataFrame")?.call1((d,))?.unbind()),
            Err(_) => Ok(d.into_any().unbind()),
        }
    }
}
